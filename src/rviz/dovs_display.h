// rviz display of the dqn_dovs/Dovs message: the velocity space drawn as in the paper's Figure 2 (w across,
// v up, DOV black, dynamic window and goal line green, the 8 actions marked), floating beside the robot in the
// message's frame. The display holds the properties and turns each message into a DovsGeometry for its visual.
#pragma once

#ifndef Q_MOC_RUN
#include <rviz/message_filter_display.h>

#include <memory>
#include <optional>

#include "dovs_geometry.h"
#include "dovs_visual.h"
#include "dqn_dovs/Dovs.h"
#endif

namespace rviz {
class BoolProperty;
class ColorProperty;
class FloatProperty;
class VectorProperty;
}  // namespace rviz

namespace dqn_dovs_rviz {

class DovsDisplay : public rviz::MessageFilterDisplay<dqn_dovs::Dovs> {
  Q_OBJECT
 public:
  DovsDisplay();
  ~DovsDisplay() override;

  /// The style the properties describe now.
  DovsStyle style() const;

 protected:
  void onInitialize() override;
  void reset() override;

 private Q_SLOTS:
  /// A property changed: repaint the last message with the new style.
  void updateStyle();

 private:
  void processMessage(const dqn_dovs::Dovs::ConstPtr& msg) override;

  std::unique_ptr<DovsVisual> visual_;
  /// The last drawn message's shapes, kept to repaint on property changes.
  std::optional<DovsGeometry> geometry_;

  rviz::FloatProperty* scale_property_;
  rviz::VectorProperty* offset_property_;
  rviz::FloatProperty* alpha_property_;
  rviz::FloatProperty* line_width_property_;
  rviz::FloatProperty* marker_size_property_;
  rviz::BoolProperty* show_intervals_property_;
  rviz::BoolProperty* show_grid_property_;
  rviz::BoolProperty* show_window_property_;
  rviz::BoolProperty* show_goal_line_property_;
  rviz::BoolProperty* show_actions_property_;
  rviz::ColorProperty* free_color_property_;
  rviz::ColorProperty* dov_color_property_;
  rviz::ColorProperty* grid_color_property_;
  rviz::ColorProperty* window_color_property_;
  rviz::ColorProperty* goal_line_color_property_;
  rviz::ColorProperty* action_color_property_;
  rviz::ColorProperty* invalid_action_color_property_;
  rviz::ColorProperty* current_color_property_;
};

}  // namespace dqn_dovs_rviz
