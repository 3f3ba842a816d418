#include "dovs_display.h"

#include <OgreQuaternion.h>
#include <OgreSceneNode.h>
#include <rviz/frame_manager.h>
#include <rviz/properties/bool_property.h>
#include <rviz/properties/color_property.h>
#include <rviz/properties/float_property.h>
#include <rviz/properties/status_property.h>
#include <rviz/properties/vector_property.h>

#include <pluginlib/class_list_macros.hpp>

namespace dqn_dovs_rviz {

namespace {

QColor toQColor(const Ogre::ColourValue& c) { return QColor::fromRgbF(c.r, c.g, c.b); }

}  // namespace

DovsDisplay::DovsDisplay() {
  const DovsStyle d;  // the defaults live in DovsStyle and OverlayPlacement
  scale_property_ = new rviz::FloatProperty(
      "Scale", static_cast<float>(d.placement.scale_m),
      "Metres per unit of normalised velocity: the kinematic triangle is 2 x Scale wide (w) and Scale tall (v).", this,
      SLOT(updateStyle()));
  scale_property_->setMin(0.01f);
  const Eigen::Vector3d& o = d.placement.offset_m;
  offset_property_ = new rviz::VectorProperty(
      "Offset", Ogre::Vector3(static_cast<float>(o.x()), static_cast<float>(o.y()), static_cast<float>(o.z())),
      "Position of the plot's origin (v = 0, w = 0) in the message's frame (the robot's base frame), m. The v axis "
      "points along the robot's heading and the w axis to its right.",
      this, SLOT(updateStyle()));
  alpha_property_ =
      new rviz::FloatProperty("Alpha", d.alpha, "Opacity of the picture, 0 to 1.", this, SLOT(updateStyle()));
  alpha_property_->setMin(0.0f);
  alpha_property_->setMax(1.0f);
  line_width_property_ = new rviz::FloatProperty(
      "Line Width", d.line_width_m, "Width of the outlines and the goal line, m.", this, SLOT(updateStyle()));
  line_width_property_->setMin(0.001f);
  marker_size_property_ = new rviz::FloatProperty("Marker Size", d.marker_size,
                                                  "Diameter of the action markers, in units of normalised velocity.",
                                                  this, SLOT(updateStyle()));
  marker_size_property_->setMin(0.001f);

  show_intervals_property_ = new rviz::BoolProperty(
      "Show DOV Intervals", d.show_intervals,
      "Fill the DOV from the per-trajectory unsafe intervals (the planner's exact view).", this, SLOT(updateStyle()));
  show_grid_property_ = new rviz::BoolProperty(
      "Show State Grid", d.show_grid,
      "Shade the unsafe (-1) cells of the network's grid (unsafe or infeasible at the cell centre).", this,
      SLOT(updateStyle()));
  show_window_property_ = new rviz::BoolProperty("Show Dynamic Window", d.show_window,
                                                 "Outline the dynamic window, clipped to the kinematic triangle.", this,
                                                 SLOT(updateStyle()));
  show_goal_line_property_ =
      new rviz::BoolProperty("Show Goal Line", d.show_goal_line,
                             "Draw the velocities whose circle passes through the goal.", this, SLOT(updateStyle()));
  show_actions_property_ = new rviz::BoolProperty(
      "Show Actions", d.show_actions, "Mark the 8 actions (masked ones small and grey) and the current velocity.", this,
      SLOT(updateStyle()));

  free_color_property_ = new rviz::ColorProperty("Free Color", toQColor(d.free_color),
                                                 "Fill of the kinematic triangle.", this, SLOT(updateStyle()));
  dov_color_property_ = new rviz::ColorProperty("DOV Color", toQColor(d.dov_color), "Fill of the DOV intervals.", this,
                                                SLOT(updateStyle()));
  grid_color_property_ = new rviz::ColorProperty("Grid Color", toQColor(d.grid_color), "Fill of the unsafe grid cells.",
                                                 this, SLOT(updateStyle()));
  window_color_property_ = new rviz::ColorProperty("Window Color", toQColor(d.window_color),
                                                   "Outline of the dynamic window.", this, SLOT(updateStyle()));
  goal_line_color_property_ = new rviz::ColorProperty("Goal Line Color", toQColor(d.goal_line_color),
                                                      "Colour of the goal line.", this, SLOT(updateStyle()));
  action_color_property_ = new rviz::ColorProperty("Action Color", toQColor(d.action_color),
                                                   "Markers of the valid actions.", this, SLOT(updateStyle()));
  invalid_action_color_property_ = new rviz::ColorProperty("Masked Action Color", toQColor(d.invalid_action_color),
                                                           "Markers of the masked actions.", this, SLOT(updateStyle()));
  current_color_property_ =
      new rviz::ColorProperty("Current Velocity Color", toQColor(d.current_color),
                              "Marker of the robot's current velocity.", this, SLOT(updateStyle()));
}

DovsDisplay::~DovsDisplay() = default;

DovsStyle DovsDisplay::style() const {
  DovsStyle s;
  s.placement.scale_m = scale_property_->getFloat();
  const Ogre::Vector3 o = offset_property_->getVector();
  s.placement.offset_m = Eigen::Vector3d(o.x, o.y, o.z);
  s.alpha = alpha_property_->getFloat();
  s.line_width_m = line_width_property_->getFloat();
  s.marker_size = marker_size_property_->getFloat();
  s.show_intervals = show_intervals_property_->getBool();
  s.show_grid = show_grid_property_->getBool();
  s.show_window = show_window_property_->getBool();
  s.show_goal_line = show_goal_line_property_->getBool();
  s.show_actions = show_actions_property_->getBool();
  s.free_color = free_color_property_->getOgreColor();
  s.dov_color = dov_color_property_->getOgreColor();
  s.grid_color = grid_color_property_->getOgreColor();
  s.window_color = window_color_property_->getOgreColor();
  s.goal_line_color = goal_line_color_property_->getOgreColor();
  s.action_color = action_color_property_->getOgreColor();
  s.invalid_action_color = invalid_action_color_property_->getOgreColor();
  s.current_color = current_color_property_->getOgreColor();
  return s;
}

void DovsDisplay::onInitialize() {
  MFDClass::onInitialize();
  visual_ = std::make_unique<DovsVisual>(context_->getSceneManager(), scene_node_);
}

void DovsDisplay::reset() {
  MFDClass::reset();
  geometry_.reset();
  if (visual_) visual_->setVisible(false);
}

void DovsDisplay::updateStyle() {
  if (visual_ && geometry_) {
    visual_->draw(*geometry_, style());
    context_->queueRender();
  }
}

void DovsDisplay::processMessage(const dqn_dovs::Dovs::ConstPtr& msg) {
  Ogre::Vector3 position;
  Ogre::Quaternion orientation;
  if (!context_->getFrameManager()->getTransform(msg->header.frame_id, msg->header.stamp, position, orientation)) {
    // The message filter only passes messages whose transform is known; this is a transform that just expired.
    setStatus(rviz::StatusProperty::Warn, "Transform",
              QString("no transform from '%1' to '%2'").arg(msg->header.frame_id.c_str(), fixed_frame_));
    return;
  }
  deleteStatus("Transform");
  try {
    geometry_ = computeDovsGeometry(*msg);
  } catch (const DovsGeometryError& e) {
    // The last good picture stays up; the status says why this message is not drawn.
    setStatus(rviz::StatusProperty::Error, "Message", e.what());
    return;
  }
  setStatus(rviz::StatusProperty::Ok, "Message",
            QString("%1 trajectories, %2 unsafe intervals%3")
                .arg(msg->trajectory_v_top.size())
                .arg(msg->interval_lo.size())
                .arg(msg->has_goal ? "" : ", no goal"));
  visual_->setFramePose(position, orientation);
  visual_->draw(*geometry_, style());
}

}  // namespace dqn_dovs_rviz

PLUGINLIB_EXPORT_CLASS(dqn_dovs_rviz::DovsDisplay, rviz::Display)
