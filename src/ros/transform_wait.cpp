#include "transform_wait.h"

#include <tf2/exceptions.h>

#include <algorithm>
#include <chrono>
#include <limits>

#include "conversions.h"

namespace dqn_dovs {

TransformWaiter::TransformWaiter(tf2::BufferCore& buffer) : buffer_(buffer) {
  callback_ = buffer_.addTransformableCallback([this](tf2::TransformableRequestHandle request, const std::string&,
                                                      const std::string&, ros::Time,
                                                      tf2::TransformableResult) { onTransformable(request); });
}

TransformWaiter::~TransformWaiter() { buffer_.removeTransformableCallback(callback_); }

void TransformWaiter::onTransformable(tf2::TransformableRequestHandle request) {
  // Called by the thread that stored the transform (the tf listener's), possibly under the buffer's request lock:
  // never call the buffer from here, and never hold mutex_ while calling the buffer elsewhere.
  {
    std::lock_guard<std::mutex> lock(mutex_);
    answered_.push_back(request);
  }
  ready_.notify_all();
}

geometry_msgs::TransformStamped TransformWaiter::lookup(const std::string& target, const std::string& source,
                                                        const ros::Time& time, double timeout_s) {
  if (timeout_s <= 0.0 || target.empty() || source.empty() || buffer_.canTransform(target, source, time)) {
    return buffer_.lookupTransform(target, source, time);  // throws with the reason when it cannot
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    answered_.clear();  // answers to earlier, abandoned requests
  }
  const tf2::TransformableRequestHandle request = buffer_.addTransformableRequest(callback_, target, source, time);
  // 0: transformable now (it arrived since canTransform); all ones: never (older than the buffer).
  if (request != 0 && request != std::numeric_limits<tf2::TransformableRequestHandle>::max()) {
    bool answered = false;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
      answered = ready_.wait_until(
          lock, deadline, [&] { return std::find(answered_.begin(), answered_.end(), request) != answered_.end(); });
    }
    if (!answered) buffer_.cancelTransformableRequest(request);
  }
  return buffer_.lookupTransform(target, source, time);
}

std::string TransformWaiter::lookupPose(const std::string& target, const std::string& source, const ros::Time& time,
                                        double timeout_s, Pose2& out) {
  geometry_msgs::TransformStamped tf;
  try {
    tf = lookup(target, source, time, timeout_s);
  } catch (const tf2::TransformException& e) {
    return "no transform " + target + " <- " + source + " at that stamp: " + e.what();
  }
  if (!poseFromTransform(tf.transform, out)) return "the " + target + " <- " + source + " transform has NaN/inf";
  return {};
}

}  // namespace dqn_dovs
