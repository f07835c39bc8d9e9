// Reads the YAML and XML files of OpenCV's cv::FileStorage (calibrateCamera's results) into
// JSON, with libyaml and pugixml rather than OpenCV's own parser: OpenCV 4.6's parser allocates
// the matrix sizes a file states before reading its data, throws std::length_error on some
// malformed keys and loops forever on some damaged YAML (a 64-byte file), so a damaged or hostile
// calibration file would hang or take the machine's memory. Private to aerovo_camera_files.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace aerovo::camera_files_detail {

/// The document of a cv::FileStorage file as JSON: the top mapping's keys in order; a plain
/// number is a JSON number, any other scalar a string (quotes dropped); a mapping an object (an
/// `!!opencv-matrix` / `type_id="opencv-matrix"` one: {"rows", "cols", "dt", "data": [...]}), a
/// sequence an array. XML when the text's first non-blank character is '<', else YAML (OpenCV's
/// "%YAML:1.0" first line read as YAML 1.1's directive). Throws InputError
/// "calibration '<path>': line <n>: <problem>" (XML: "at byte <offset>") for a syntax error, a
/// top that is not a mapping, nesting deeper than 16 levels, more than 100000 values, an alias,
/// a key given twice.
nlohmann::json ParseOpenCvStorage(const std::string& text, const std::string& path);

}  // namespace aerovo::camera_files_detail
