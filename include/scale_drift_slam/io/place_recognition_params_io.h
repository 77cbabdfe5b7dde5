#pragma once
// Reading loop::PlaceRecognitionParams from YAML (config/place_recognition.yaml documents every
// key). The keys sit at the top level or under `place_recognition:` (so a whole-system config can
// hold them); absent keys keep their defaults, an unknown key is an error (a typo must not pass
// silently), and the result is validated.

#include <string>

#include "scale_drift_slam/loop/place_recognition_params.h"

namespace scale_drift_slam::io {

/// Throws std::runtime_error naming the file and the key (missing file, not YAML, unknown key,
/// wrong kind of value, invalid value). A relative vocabulary_file is taken relative to the
/// folder of the YAML file.
loop::PlaceRecognitionParams loadPlaceRecognitionParams(const std::string& path);
/// Parses YAML text; `origin` names the source in error messages.
loop::PlaceRecognitionParams parsePlaceRecognitionParams(const std::string& text,
                                                         const std::string& origin = "<string>");

}  // namespace scale_drift_slam::io
