// The Ogre objects of one DOVS picture: filled shapes (free triangle, network grid, DOV) in one ManualObject,
// outlines (triangle, dynamic window, goal line) as billboard lines, and the action and current-velocity markers.
// All positions come from dovs_geometry; this class only owns and paints the objects.
#pragma once

#include <OgreColourValue.h>
#include <OgreMaterial.h>
#include <OgreQuaternion.h>
#include <OgreVector.h>

#include <array>
#include <memory>

#include "dovs_geometry.h"

namespace Ogre {
class ManualObject;
class SceneManager;
class SceneNode;
}  // namespace Ogre

namespace rviz {
class BillboardLine;
class Shape;
}  // namespace rviz

namespace dqn_dovs_rviz {

/// How the picture is painted (the display's properties). Defaults follow the paper's figure: white free
/// triangle, black DOV, green window and goal line.
struct DovsStyle {
  /// Where the picture floats in the robot frame and how large it is.
  OverlayPlacement placement;
  /// Opacity of the filled shapes and lines, in [0, 1].
  float alpha = 0.8f;
  /// Width of the outlines and the goal line, m.
  float line_width_m = 0.02f;
  /// Diameter of the action markers, in units of normalised velocity (scaled with the picture).
  float marker_size = 0.05f;
  Ogre::ColourValue free_color{1.0f, 1.0f, 1.0f};
  Ogre::ColourValue dov_color{0.0f, 0.0f, 0.0f};
  Ogre::ColourValue grid_color{0.85f, 0.2f, 0.2f};
  Ogre::ColourValue outline_color{0.25f, 0.25f, 0.25f};
  Ogre::ColourValue window_color{0.0f, 0.8f, 0.0f};
  Ogre::ColourValue goal_line_color{0.0f, 0.6f, 0.0f};
  Ogre::ColourValue action_color{0.0f, 0.35f, 0.8f};
  Ogre::ColourValue invalid_action_color{0.5f, 0.5f, 0.5f};
  Ogre::ColourValue current_color{0.9f, 0.0f, 0.0f};
  bool show_intervals = true;
  bool show_grid = false;
  bool show_window = true;
  bool show_goal_line = true;
  bool show_actions = true;
};

class DovsVisual {
 public:
  /// Creates the objects under a new child of parent_node (the display's scene node).
  DovsVisual(Ogre::SceneManager* scene_manager, Ogre::SceneNode* parent_node);
  ~DovsVisual();
  DovsVisual(const DovsVisual&) = delete;
  DovsVisual& operator=(const DovsVisual&) = delete;

  /// Redraws everything from `geometry` painted with `style`, and shows the picture.
  void draw(const DovsGeometry& geometry, const DovsStyle& style);
  /// Hides or shows the picture (hidden from construction until the first draw).
  void setVisible(bool visible);

  /// Pose of the robot frame (the Dovs message's frame) in the fixed frame.
  void setFramePose(const Ogre::Vector3& position, const Ogre::Quaternion& orientation);

 private:
  void drawFills(const DovsGeometry& geometry, const DovsStyle& style);
  void drawLines(const DovsGeometry& geometry, const DovsStyle& style);
  void drawMarkers(const DovsGeometry& geometry, const DovsStyle& style);

  Ogre::SceneManager* scene_manager_;
  Ogre::SceneNode* frame_node_;
  Ogre::ManualObject* fills_;
  Ogre::MaterialPtr fill_material_;
  std::unique_ptr<rviz::BillboardLine> triangle_outline_;
  std::unique_ptr<rviz::BillboardLine> window_outline_;
  std::unique_ptr<rviz::BillboardLine> goal_line_;
  std::array<std::unique_ptr<rviz::Shape>, kNumActionPoints> action_markers_;
  std::unique_ptr<rviz::Shape> current_marker_;
};

}  // namespace dqn_dovs_rviz
