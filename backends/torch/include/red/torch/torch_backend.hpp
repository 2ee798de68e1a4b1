#pragma once
/// \file
/// The runtime's LibTorch backend (docs/DESIGN.md, "Synchronization" and "Built-in model"):
/// synthetic camera frames as real tensors in memory, real inference of the scenario's model (the
/// built-in MIMONet or a manifest's TorchScript modules). Merged members share one encoder output;
/// a batch runs as one tensor batch. On a CUDA device each lane gets its own CUDA stream.

#include <memory>
#include <string>

#include "red/core/expected.hpp"
#include "red/runtime/backend.hpp"
#include "red/scenario/scenario.hpp"
#include "red/torch/lane_device.hpp"

namespace red::torchb {

/// A LibTorch backend for the scenario's model on `device` ("cpu", "cuda", "cuda:N") with
/// `threads` intra-op threads (0: LibTorch's default). Errors name the model file.
///
/// On a GPU the backend is asynchronous (Backend::asynchronous()): a lane enqueues units on
/// its stream and waits for them in order. `asynchronous` makes a CPU backend asynchronous
/// too, so that the runtime's asynchronous path runs without a GPU (tests): enqueue() then
/// runs the unit at once and keeps how it ended, and wait() reports that. Ignored on a GPU.
///
/// `lanes`, when given, is the device under the lanes in place of the model's own (a
/// stand-in whose events complete late, hang or fail, for tests; LaneDevice): the model
/// still runs on `device`, and every stream, event and copy of the lanes is the stand-in's,
/// as on a GPU. Null: the model's device, when it is not the CPU.
Expected<std::unique_ptr<Backend>> make_torch_backend(const Scenario& s, const std::string& device,
                                                      int threads, bool asynchronous = false,
                                                      std::shared_ptr<LaneDevice> lanes = nullptr);

}  // namespace red::torchb
