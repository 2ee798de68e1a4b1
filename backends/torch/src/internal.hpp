#pragma once
/// \file
/// Shared between the backend's sources; not installed.

#include <exception>
#include <memory>
#include <string>

#include "red/core/expected.hpp"
#include "red/torch/model.hpp"

namespace red::torchb::detail {

/// The built-in MIMONet (mimonet.cpp). `heads` are checked names, `device` parsed.
Expected<std::unique_ptr<Model>> create_mimonet(const ModelOptions& options,
                                                const std::vector<std::string>& heads,
                                                const c10::Device& device);

/// A TorchScript model from a manifest (script_model.cpp).
Expected<std::unique_ptr<Model>> create_script_model(const ModelOptions& options,
                                                     const c10::Device& device);

/// The first line of an exception's message, without LibTorch's C++ backtrace.
std::string describe(const std::exception& e);

/// "[3,192,384]".
std::string shape_string(const std::vector<std::int64_t>& shape);

}  // namespace red::torchb::detail
