#include "aerovo/camera_files/opencv_storage.h"

#include <cstring>
#include <optional>
#include <string_view>

#include <fmt/format.h>
#include <pugixml.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/text.h"
#include "aerovo/yaml/yaml_events.h"

namespace aerovo::camera_files_detail {
namespace {

// Deeper than any calibration (a matrix in the top mapping is 2 levels).
constexpr int kMaxDepth = 16;
// Values in a document; a calibration holds a few dozen (a 14-coefficient distortion).
constexpr std::size_t kMaxValues = 100000;

// A plain scalar: a finite decimal number (ParseDecimal, core/text.h) as a JSON number, else
// the text.
nlohmann::json Scalar(std::string_view text) {
  const std::string_view t = TrimSpace(text);
  if (const std::optional<double> v = ParseDecimal(t)) return *v;
  return std::string(t);
}

// ---- YAML (libyaml events) ----------------------------------------------------------------------

class YamlDocument {
 public:
  YamlDocument(const std::string& text, const std::string& path)
      : text_(Prepared(text)), events_(text_, fmt::format("calibration '{}'", path)) {}

  nlohmann::json Read() {
    std::optional<YamlEvent> top = events_.TopMapping(
        "not a map of keys at the top (an OpenCV calibration file holds image_width, "
        "image_height, camera_matrix ...)");
    if (!top) throw InputError(events_.where() + ": an empty YAML document");
    nlohmann::json root = Node(*top, 0);
    events_.ExpectEnd("a second YAML document (a calibration file holds one)");
    return root;
  }

 private:
  // OpenCV writes its own "%YAML:1.0" first line; libyaml knows "%YAML 1.1" only. The line is
  // emptied (line numbers stay those of the file).
  // (after a UTF-8 byte order mark, dropped too; "%YAML 1.0" and "%YAML 1.2" alike).
  static std::string Prepared(std::string text) {
    if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);
    if (text.rfind("%YAML", 0) == 0) {
      const std::size_t end = text.find('\n');
      text.replace(0, end == std::string::npos ? text.size() : end, "");
    }
    return text;
  }

  void Count(const YamlEvent& ev) {
    if (++values_ > kMaxValues) {
      throw events_.Error(
          ev, fmt::format("more than {} values (a calibration holds a few dozen)", kMaxValues));
    }
  }

  nlohmann::json Node(const YamlEvent& ev, int depth) {
    Count(ev);
    if ((ev.e.type == YAML_SEQUENCE_START_EVENT || ev.e.type == YAML_MAPPING_START_EVENT) &&
        depth + 1 > kMaxDepth) {
      throw events_.Error(ev, fmt::format("nested deeper than {} levels", kMaxDepth));
    }
    switch (ev.e.type) {
      case YAML_SCALAR_EVENT: {
        if (!ev.plain()) return std::string(ev.scalar());
        return Scalar(ev.scalar());
      }
      case YAML_ALIAS_EVENT:
        throw events_.Error(ev, "an alias (*name): not read in a calibration file");
      case YAML_SEQUENCE_START_EVENT: {
        nlohmann::json arr = nlohmann::json::array();
        for (;;) {
          const YamlEvent item = events_.Next();
          if (item.e.type == YAML_SEQUENCE_END_EVENT) break;
          arr.push_back(Node(item, depth + 1));
        }
        return arr;
      }
      case YAML_MAPPING_START_EVENT: {
        nlohmann::json obj = nlohmann::json::object();
        for (;;) {
          const YamlEvent k = events_.Next();
          if (k.e.type == YAML_MAPPING_END_EVENT) break;
          if (k.e.type != YAML_SCALAR_EVENT) throw events_.Error(k, "a key must be a plain scalar");
          const std::string key(k.scalar());
          if (obj.contains(key))
            throw events_.Error(k, fmt::format("key '{}' is given twice", Printable(key)));
          const YamlEvent v = events_.Next();
          obj[key] = Node(v, depth + 1);
        }
        return obj;
      }
      default:
        throw events_.Error(ev, "unexpected YAML event");
    }
  }

  std::string text_;  // the file's text as libyaml reads it (Prepared)
  YamlEvents events_;
  std::size_t values_ = 0;
};

// ---- XML (pugixml) ------------------------------------------------------------------------------

// An element: a matrix (type_id="opencv-matrix": rows, cols, dt, and data split at blanks), a
// mapping of its child elements, or a scalar of its text.
nlohmann::json XmlNode(const pugi::xml_node& e, const std::string& path, int depth,
                       std::size_t& values) {
  if (depth > kMaxDepth) {
    throw InputError(fmt::format("calibration '{}' at byte {}: nested deeper than {} levels", path,
                                 e.offset_debug(), kMaxDepth));
  }
  if (++values > kMaxValues) {
    throw InputError(fmt::format("calibration '{}': more than {} values", path, kMaxValues));
  }
  bool has_children = false;
  for (const pugi::xml_node& c : e.children()) has_children |= c.type() == pugi::node_element;
  if (!has_children) {
    std::string_view text = TrimSpace(e.text().get());
    if (text.size() >= 2 && text.front() == '"' && text.back() == '"') {
      return std::string(text.substr(1, text.size() - 2));
    }
    return Scalar(text);
  }
  const bool matrix = std::strcmp(e.attribute("type_id").value(), "opencv-matrix") == 0;
  nlohmann::json obj = nlohmann::json::object();
  for (const pugi::xml_node& c : e.children()) {
    if (c.type() != pugi::node_element) continue;
    const std::string key = c.name();
    if (obj.contains(key)) {
      throw InputError(fmt::format("calibration '{}' at byte {}: key '{}' is given twice", path,
                                   c.offset_debug(), Printable(key)));
    }
    if (matrix && key == "data") {
      nlohmann::json data = nlohmann::json::array();
      const std::string_view all = c.text().get();
      std::size_t at = 0;
      while (at < all.size()) {
        const std::size_t begin = all.find_first_not_of(" \t\r\n", at);
        if (begin == std::string_view::npos) break;
        std::size_t end = all.find_first_of(" \t\r\n", begin);
        if (end == std::string_view::npos) end = all.size();
        if (++values > kMaxValues) {
          throw InputError(fmt::format("calibration '{}': more than {} values", path, kMaxValues));
        }
        data.push_back(Scalar(all.substr(begin, end - begin)));
        at = end;
      }
      obj[key] = std::move(data);
    } else {
      obj[key] = XmlNode(c, path, depth + 1, values);
    }
  }
  return obj;
}

nlohmann::json ReadXml(const std::string& text, const std::string& path) {
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_buffer(text.data(), text.size());
  if (!parsed) {
    throw InputError(fmt::format("calibration '{}' at byte {}: not valid XML ({})", path,
                                 parsed.offset, parsed.description()));
  }
  const pugi::xml_node top = doc.document_element();
  if (std::strcmp(top.name(), "opencv_storage") != 0) {
    throw InputError(fmt::format(
        "calibration '{}': the XML's top element is <{}>, not <opencv_storage> (OpenCV's)", path,
        top.name()));
  }
  std::size_t values = 0;
  nlohmann::json root = XmlNode(top, path, 0, values);
  if (!root.is_object()) root = nlohmann::json::object();  // <opencv_storage/> holds no key
  return root;
}

}  // namespace

nlohmann::json ParseOpenCvStorage(const std::string& text, const std::string& path) {
  const std::string_view t = TrimSpace(text);
  if (!t.empty() && t.front() == '<') return ReadXml(text, path);
  return YamlDocument(text, path).Read();
}

}  // namespace aerovo::camera_files_detail
