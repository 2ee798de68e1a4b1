#pragma once
/// \file
/// The model manifest of a user's TorchScript multi-task model lives in the core library
/// (red/scenario/manifest.hpp), so that `red validate` can check it without LibTorch. The
/// backend's names for it, kept for its code and tests.

#include "red/scenario/manifest.hpp"

namespace red::torchb {

using Manifest = ::red::ModelManifest;
using ::red::FeatureForm;
using ::red::load_manifest;
using ::red::ManifestFile;
using ::red::parse_manifest;

}  // namespace red::torchb
