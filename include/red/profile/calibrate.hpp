#pragma once
/// \file
/// Moved: calibration is its own module above metrics, red/calibrate/calibrate.hpp. This header
/// only forwards there, for code that included the old path.
#include "red/calibrate/calibrate.hpp"  // IWYU pragma: export
