// Looking up a transform at a message's stamp, waiting for it when it has not arrived yet.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <tf2/buffer_core.h>

#include <condition_variable>
#include <mutex>
#include <string>
#include <vector>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

/// tf2's lookupTransform at a given time, waiting up to a timeout for data that has not arrived yet. The wait
/// ends the moment the tf listener stores the transform (a transformable request on the buffer), not at the next
/// try of a polling loop: tf2_ros::Buffer::lookupTransform with a timeout sleeps about 1 ms between tries, and the
/// transform of a scan often arrives a few microseconds after the scan itself (docs/performance.md, "End to end").
/// One waiter serves one thread at a time (a node's single-threaded callback queue); the buffer must outlive it.
class TransformWaiter {
 public:
  explicit TransformWaiter(tf2::BufferCore& buffer);
  ~TransformWaiter();
  TransformWaiter(const TransformWaiter&) = delete;
  TransformWaiter& operator=(const TransformWaiter&) = delete;

  /// The transform target <- source at `time`, waiting up to `timeout_s` of wall-clock time for it (0: no wait).
  /// Throws tf2::TransformException with the buffer's own reason when it is still not available (unknown or
  /// empty frame, extrapolation, older than the buffer) once the wait is over.
  geometry_msgs::TransformStamped lookup(const std::string& target, const std::string& source, const ros::Time& time,
                                         double timeout_s);
  /// The same as a planar pose of `source` in `target` (`out`); "" when found, otherwise why not: "no transform
  /// T <- S at that stamp: <the buffer's reason>" or "the T <- S transform has NaN/inf". Never throws.
  std::string lookupPose(const std::string& target, const std::string& source, const ros::Time& time, double timeout_s,
                         Pose2& out);

 private:
  void onTransformable(tf2::TransformableRequestHandle request);

  tf2::BufferCore& buffer_;
  tf2::TransformableCallbackHandle callback_ = 0;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::vector<tf2::TransformableRequestHandle> answered_;  ///< requests the buffer has answered since the last lookup
};

}  // namespace dqn_dovs
