// The DOVS display is registered with rviz and loads through pluginlib exactly as rviz loads it: found from the
// package's export in package.xml, its library opened from the library path (this test does not link it).
// Needs the package on ROS_PACKAGE_PATH and its library prefix on CMAKE_PREFIX_PATH: run it through the devel
// space's env.sh (ctest and colcon test do). A display owns ROS node handles, whose creation registers with a
// master: the test starts its own rosmaster on a free port.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <ros/ros.h>
#include <rviz/display.h>
#include <rviz/properties/float_property.h>
#include <rviz/properties/ros_topic_property.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <QApplication>
#include <QString>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <pluginlib/class_loader.hpp>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace {

constexpr const char* kLookupName = "dqn_dovs/Dovs";

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::vector<std::string> childNames(const rviz::Property& p) {
  std::vector<std::string> names;
  for (int i = 0; i < p.numChildren(); ++i) names.push_back(p.childAt(i)->getNameStd());
  return names;
}

TEST(RvizPlugin, DovsDisplayIsDeclared) {
  pluginlib::ClassLoader<rviz::Display> loader("rviz", "rviz::Display");
  const std::vector<std::string> declared = loader.getDeclaredClasses();
  // rviz's own displays are found the same way: the search itself works.
  ASSERT_TRUE(loader.isClassAvailable("rviz/Grid")) << "declared: " << joined(declared);
  ASSERT_TRUE(loader.isClassAvailable(kLookupName)) << "declared: " << joined(declared);
  EXPECT_EQ(loader.getClassType(kLookupName), "dqn_dovs_rviz::DovsDisplay");
  EXPECT_EQ(loader.getClassPackage(kLookupName), "dqn_dovs");
  EXPECT_EQ(loader.getBaseClassType(), "rviz::Display");
  EXPECT_NE(loader.getClassDescription(kLookupName).find("Velocity Space"), std::string::npos);
  const std::string library = loader.getClassLibraryPath(kLookupName);
  EXPECT_NE(library.find("libdqn_dovs_rviz.so"), std::string::npos) << library;
  EXPECT_TRUE(std::ifstream(library).good()) << library;
}

TEST(RvizPlugin, DovsDisplayLoadsWithItsProperties) {
  pluginlib::ClassLoader<rviz::Display> loader("rviz", "rviz::Display");
  EXPECT_FALSE(loader.isClassLoaded(kLookupName));
  // rviz's MessageFilterDisplay can only be destroyed after onInitialize (which needs a render window): the
  // instance is left alive, as rviz itself never destroys an uninitialised display.
  rviz::Display* display = nullptr;
  ASSERT_NO_THROW(display = loader.createUnmanagedInstance(kLookupName));
  ASSERT_NE(display, nullptr);
  EXPECT_TRUE(loader.isClassLoaded(kLookupName));

  const std::vector<std::string> names = childNames(*display);
  for (const char* expected :
       {"Topic", "Scale", "Offset", "Alpha", "Line Width", "Marker Size", "Show DOV Intervals", "Show State Grid",
        "Show Dynamic Window", "Show Goal Line", "Show Actions", "Free Color", "DOV Color", "Grid Color",
        "Window Color", "Goal Line Color", "Action Color", "Masked Action Color", "Current Velocity Color"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end())
        << "no property '" << expected << "' among: " << joined(names);
  }
  // The topic property offers only Dovs topics; the scale is in metres per unit of normalised velocity.
  auto* topic = dynamic_cast<rviz::RosTopicProperty*>(display->subProp("Topic"));
  ASSERT_NE(topic, nullptr);
  EXPECT_EQ(topic->getMessageType().toStdString(), "dqn_dovs/Dovs");
  auto* scale = dynamic_cast<rviz::FloatProperty*>(display->subProp("Scale"));
  ASSERT_NE(scale, nullptr);
  EXPECT_FLOAT_EQ(scale->getFloat(), 1.0f);
  EXPECT_TRUE(scale->setValue(2.5f));
  EXPECT_FLOAT_EQ(scale->getFloat(), 2.5f);
  EXPECT_FALSE(display->subProp("Show State Grid")->getValue().toBool());
  EXPECT_TRUE(display->subProp("Show DOV Intervals")->getValue().toBool());
}

// A port nobody listens on now (the kernel's choice for an ephemeral bind), or 0.
int freeTcpPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
    port = ntohs(addr.sin_port);
  }
  close(fd);
  return port;
}

// A rosmaster of this test's own, stopped when the test ends.
class PrivateMaster {
 public:
  PrivateMaster() {
    const int port = freeTcpPort();
    if (port == 0) return;
    const std::string port_text = std::to_string(port);
    setenv("ROS_MASTER_URI", ("http://127.0.0.1:" + port_text).c_str(), 1);
    std::vector<std::string> args{"rosmaster", "--core", "-p", port_text, "-w", "1"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawnp(&pid_, "rosmaster", nullptr, nullptr, argv.data(), environ) != 0) pid_ = -1;
  }
  ~PrivateMaster() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }
  bool started() const { return pid_ > 0; }

 private:
  pid_t pid_ = -1;
};

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  PrivateMaster master;
  if (!master.started()) {
    std::fprintf(stderr, "test_rviz_plugin: could not start rosmaster (is it on PATH?)\n");
    return 1;
  }
  ros::init(argc, argv, "test_rviz_plugin", ros::init_options::AnonymousName | ros::init_options::NoRosout);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!ros::master::check()) {
    if (std::chrono::steady_clock::now() > deadline) {
      std::fprintf(stderr, "test_rviz_plugin: rosmaster at %s did not answer within 20 s\n",
                   ros::master::getURI().c_str());
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  // Qt objects need an application, not a screen.
  setenv("QT_QPA_PLATFORM", "offscreen", 1);
  QApplication app(argc, argv);
  return RUN_ALL_TESTS();
}
