#include "dovs_visual.h"

#include <OgreManualObject.h>
#include <OgreMaterialManager.h>
#include <OgreSceneManager.h>
#include <OgreSceneNode.h>
#include <OgreTechnique.h>
#include <rviz/ogre_helpers/billboard_line.h>
#include <rviz/ogre_helpers/shape.h>

#include <algorithm>
#include <atomic>
#include <string>

namespace dqn_dovs_rviz {

namespace {

// Heights of the stacked layers, in units of normalised velocity: the DOV sits on the grid, the grid on the free
// triangle, outlines and markers on top, so that nothing z-fights when seen from above.
constexpr double kLayerFree = 0.0;
constexpr double kLayerGrid = 0.002;
constexpr double kLayerDov = 0.004;
constexpr double kLayerLines = 0.006;
constexpr double kLayerMarkers = 0.01;

Ogre::Vector3 toOgre(const Eigen::Vector3d& p) {
  return {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
}

Ogre::ColourValue withAlpha(Ogre::ColourValue c, float alpha) {
  c.a = alpha;
  return c;
}

// Triangle fan of a convex polygon into the open ManualObject section.
void addConvexPolygon(Ogre::ManualObject& object, const Polygon& polygon, const OverlayPlacement& placement,
                      double layer, const Ogre::ColourValue& colour) {
  for (size_t k = 1; k + 1 < polygon.size(); ++k) {
    for (const PlotPoint* p : {&polygon[0], &polygon[k], &polygon[k + 1]}) {
      object.position(toOgre(plotToRobot(*p, placement, layer)));
      object.colour(colour);
    }
  }
}

void setLine(rviz::BillboardLine& line, const std::vector<PlotPoint>& points, bool closed, const DovsStyle& style,
             const Ogre::ColourValue& colour) {
  line.clear();
  if (points.size() < 2) return;
  const Ogre::ColourValue c = withAlpha(colour, style.alpha);
  line.setLineWidth(style.line_width_m);
  line.setColor(c.r, c.g, c.b, c.a);
  line.setMaxPointsPerLine(static_cast<uint32_t>(points.size() + (closed ? 1 : 0)));
  line.setNumLines(1);
  for (const PlotPoint& p : points) line.addPoint(toOgre(plotToRobot(p, style.placement, kLayerLines)), c);
  if (closed) line.addPoint(toOgre(plotToRobot(points.front(), style.placement, kLayerLines)), c);
}

}  // namespace

DovsVisual::DovsVisual(Ogre::SceneManager* scene_manager, Ogre::SceneNode* parent_node)
    : scene_manager_(scene_manager), frame_node_(parent_node->createChildSceneNode()) {
  static std::atomic<int> instances{0};
  const std::string name = "dqn_dovs_rviz_dovs_fill_" + std::to_string(instances++);
  fill_material_ =
      Ogre::MaterialManager::getSingleton().create(name, Ogre::ResourceGroupManager::DEFAULT_RESOURCE_GROUP_NAME);
  fill_material_->setReceiveShadows(false);
  fill_material_->getTechnique(0)->setLightingEnabled(false);  // vertex colours as they are
  fill_material_->setCullingMode(Ogre::CULL_NONE);             // visible from below as well
  fill_material_->setSceneBlending(Ogre::SBT_TRANSPARENT_ALPHA);
  fill_material_->setDepthWriteEnabled(false);

  fills_ = scene_manager_->createManualObject();
  fills_->setDynamic(true);
  frame_node_->attachObject(fills_);

  triangle_outline_ = std::make_unique<rviz::BillboardLine>(scene_manager_, frame_node_);
  window_outline_ = std::make_unique<rviz::BillboardLine>(scene_manager_, frame_node_);
  goal_line_ = std::make_unique<rviz::BillboardLine>(scene_manager_, frame_node_);
  for (auto& marker : action_markers_)
    marker = std::make_unique<rviz::Shape>(rviz::Shape::Sphere, scene_manager_, frame_node_);
  current_marker_ = std::make_unique<rviz::Shape>(rviz::Shape::Cube, scene_manager_, frame_node_);
  frame_node_->setVisible(false);  // nothing meaningful before the first message
}

DovsVisual::~DovsVisual() {
  triangle_outline_.reset();
  window_outline_.reset();
  goal_line_.reset();
  for (auto& marker : action_markers_) marker.reset();
  current_marker_.reset();
  scene_manager_->destroyManualObject(fills_);
  Ogre::MaterialManager::getSingleton().remove(fill_material_);
  scene_manager_->destroySceneNode(frame_node_);
}

void DovsVisual::setFramePose(const Ogre::Vector3& position, const Ogre::Quaternion& orientation) {
  frame_node_->setPosition(position);
  frame_node_->setOrientation(orientation);
}

void DovsVisual::draw(const DovsGeometry& geometry, const DovsStyle& style) {
  setVisible(true);  // first: it cascades, and drawMarkers then hides the markers that are switched off
  drawFills(geometry, style);
  drawLines(geometry, style);
  drawMarkers(geometry, style);
}

void DovsVisual::setVisible(bool visible) { frame_node_->setVisible(visible); }

void DovsVisual::drawFills(const DovsGeometry& geometry, const DovsStyle& style) {
  fills_->clear();
  const OverlayPlacement& at = style.placement;
  size_t triangles = geometry.triangle.size() >= 3 ? geometry.triangle.size() - 2 : 0;
  if (style.show_grid) {
    for (const Polygon& p : geometry.grid_unsafe_cells) triangles += p.size() >= 3 ? p.size() - 2 : 0;
  }
  if (style.show_intervals) {
    for (const Polygon& p : geometry.dov) triangles += p.size() >= 3 ? p.size() - 2 : 0;
  }
  if (triangles == 0) return;  // an empty section is not allowed
  fills_->estimateVertexCount(3 * triangles);
  fills_->begin(fill_material_->getName(), Ogre::RenderOperation::OT_TRIANGLE_LIST,
                Ogre::ResourceGroupManager::DEFAULT_RESOURCE_GROUP_NAME);
  // Drawn in this order without depth writes, later shapes blend over earlier ones.
  addConvexPolygon(*fills_, geometry.triangle, at, kLayerFree, withAlpha(style.free_color, style.alpha));
  if (style.show_grid) {
    const Ogre::ColourValue c = withAlpha(style.grid_color, 0.6f * style.alpha);
    for (const Polygon& p : geometry.grid_unsafe_cells) addConvexPolygon(*fills_, p, at, kLayerGrid, c);
  }
  if (style.show_intervals) {
    const Ogre::ColourValue c = withAlpha(style.dov_color, style.alpha);
    for (const Polygon& p : geometry.dov) addConvexPolygon(*fills_, p, at, kLayerDov, c);
  }
  fills_->end();
}

void DovsVisual::drawLines(const DovsGeometry& geometry, const DovsStyle& style) {
  setLine(*triangle_outline_, geometry.triangle, true, style, style.outline_color);
  if (style.show_window) {
    setLine(*window_outline_, geometry.window, true, style, style.window_color);
  } else {
    window_outline_->clear();
  }
  if (style.show_goal_line) {
    setLine(*goal_line_, geometry.goal_line, false, style, style.goal_line_color);
  } else {
    goal_line_->clear();
  }
}

void DovsVisual::drawMarkers(const DovsGeometry& geometry, const DovsStyle& style) {
  const float size = style.marker_size * static_cast<float>(style.placement.scale_m);
  const Ogre::Vector3 scale(size, size, size);
  for (size_t i = 0; i < kNumActionPoints; ++i) {
    rviz::Shape& marker = *action_markers_[i];
    const ActionPoint& a = geometry.actions[i];
    const bool shown = style.show_actions && a.position.allFinite();
    marker.getRootNode()->setVisible(shown);
    if (!shown) continue;
    marker.setPosition(toOgre(plotToRobot(a.position, style.placement, kLayerMarkers)));
    // Masked actions are smaller and grey: still visible, so a masked goal action is noticed.
    marker.setScale(a.valid ? scale : 0.6f * scale);
    const Ogre::ColourValue& c = a.valid ? style.action_color : style.invalid_action_color;
    marker.setColor(c.r, c.g, c.b, std::max(style.alpha, 0.3f));
  }
  current_marker_->getRootNode()->setVisible(style.show_actions);
  current_marker_->setPosition(toOgre(plotToRobot(geometry.current, style.placement, kLayerMarkers)));
  current_marker_->setScale(Ogre::Vector3(0.8f * size, 0.8f * size, 0.8f * size));
  const Ogre::ColourValue& c = style.current_color;
  current_marker_->setColor(c.r, c.g, c.b, std::max(style.alpha, 0.3f));
}

}  // namespace dqn_dovs_rviz
