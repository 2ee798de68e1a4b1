#pragma once
/// \file
/// `red camera` (docs/ROS2.md): publishes sensor_msgs/Image frames at a rate, for demos and tests
/// (the paper's simulated camera node). Frames are synthetic -- a gradient with a bright
/// square that moves, so that every output of `red node` changes with the frame -- or the
/// PNG/JPEG images of a directory, in name order, in a loop.

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>

#include "red/core/expected.hpp"
#include "red/core/time.hpp"
#include "red/dds/ros.hpp"
#include "red/dds/security.hpp"

namespace red::dds {

/// Options of a camera publisher.
struct CameraOptions {
  double rate_hz = 30.0;
  std::string topic = "/camera/image_raw";
  int width = 640;
  int height = 480;
  std::string encoding = "rgb8";  ///< rgb8, bgr8 or mono8
  std::string frame_id = "camera";
  std::string from_dir;  ///< publish these images (their own size) instead of synthetic ones
  std::optional<std::uint64_t> count;  ///< stop after this many frames
  std::optional<Duration> duration;    ///< stop after this long
  int domain = 0;
  std::string config;          ///< Cyclone DDS XML or file:// URI; empty: loopback only
  bool shared_memory = false;  ///< through iceoryx shared memory (Domain::open; RouDi must run)
  std::optional<Enclave> security;  ///< DDS Security with this SROS2 enclave; none: open
  EndpointQos qos = QosSettings{}.input;
  /// When set, each frame's header also goes out on this topic (std_msgs/msg/Header,
  /// reliable), so that a probe (bench/ros2/listener.cpp) counts the frames sent without
  /// subscribing to their pixels, which would double what the camera sends per frame.
  std::string stamps_topic;
  /// Wait up to this long for a subscriber before the first frame (best effort drops
  /// frames nobody receives yet).
  Duration wait_for_subscriber = std::chrono::seconds{5};
  /// Leave out every n-th frame (0: none): its time passes and nothing is sent, as if the
  /// link lost it, to check that a subscriber counts what it did not get.
  std::uint64_t skip_every = 0;
};

/// What a camera did.
struct CameraReport {
  std::uint64_t published = 0;
  std::uint64_t skipped = 0;  ///< left out by skip_every
  bool matched = false;       ///< a subscriber was there when publishing began
};

/// Publishes until `stop`, the count or the duration. Error: bad options, DDS failure.
Expected<CameraReport> run_camera(const CameraOptions& o, const std::atomic<bool>& stop);

}  // namespace red::dds
