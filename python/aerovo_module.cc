// `import aerovo`: aerovo's SURF, correspondence stage, visual odometry and run-folder reader
// for Python (pybind11), on numpy arrays. docs/python.md shows how it is used.
//
// Images: numpy uint8 arrays, 2-D (height, width) grey, or 3-D (height, width, 1 | 3 | 4);
// colour becomes grey with cv::cvtColor (0.299 R + 0.587 G + 0.114 B, fixed point), the
// formula of frames' ReadGrayImage (GrayFrom::kColor) and of the frame sources; channels="rgb"
// (numpy's usual order: imageio, PIL, matplotlib) or "bgr" (cv2.imread). Any other dtype is a
// TypeError, any other shape a ValueError; arrays that are not C-contiguous are copied.
// The heavy calls (SURF, the correspondence stage, VisualOdometry.process) release the GIL;
// each object serialises its own calls (one mutex each), so sharing one between threads is
// safe, if not parallel.
// Errors: aerovo::InvalidArgument -> ValueError, aerovo::InputError -> aerovo.InputError (a
// ValueError), aerovo::OutputError -> aerovo.OutputError (an OSError: a write that failed);
// the messages are the C++ ones (they name the field, file or frame).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "aerovo/core/error.h"
#include "aerovo/correspondence/correspondence.h"
#include "aerovo/features/surf.h"
#include "aerovo/frames/image_file.h"
#include "aerovo/odometry/visual_odometry.h"
#include "aerovo/report/run_reader.h"
#include "aerovo/version.h"
#include "options_binding.h"

namespace py = pybind11;

namespace aerovo::python {
namespace {

// ------------------------------------------------------------------------------------------
// Images

/// A grey view of a numpy image and what keeps its pixels alive.
struct GrayInput {
  py::array array;  // the (contiguous) uint8 array
  cv::Mat converted;  // the grey image when the input was colour
  GrayImageView view;
};

std::string ShapeText(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    s += (i ? ", " : "") + std::to_string(a.shape(i));
  }
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/// The conversion every image argument goes through (see the header comment). With the GIL.
GrayInput ToGray(py::handle image, const std::string& channels) {
  if (channels != "rgb" && channels != "bgr") {
    throw py::value_error("channels must be 'rgb' or 'bgr', got '" + channels + "'");
  }
  if (!py::isinstance<py::array>(image)) {
    throw py::type_error("image must be a numpy array of dtype uint8, got " + PyTypeName(image));
  }
  py::array a = py::reinterpret_borrow<py::array>(image);
  if (!a.dtype().is(py::dtype::of<std::uint8_t>())) {
    throw py::type_error("image must be a numpy array of dtype uint8 (8-bit grey or colour), got " +
                         py::str(a.dtype()).cast<std::string>() +
                         "; e.g. numpy.clip(image * 255, 0, 255).astype(numpy.uint8) for floats "
                         "in [0, 1]");
  }
  const bool grey2d = a.ndim() == 2;
  const bool colour = a.ndim() == 3 && (a.shape(2) == 1 || a.shape(2) == 3 || a.shape(2) == 4);
  if (!grey2d && !colour) {
    throw py::value_error("image must be 2-D (height, width) or 3-D (height, width, 1 | 3 | 4), "
                          "got shape " + ShapeText(a));
  }
  if (a.size() == 0) throw py::value_error("image is empty (shape " + ShapeText(a) + ")");
  if (a.shape(0) > std::numeric_limits<int>::max() / 8 ||
      a.shape(1) > std::numeric_limits<int>::max() / 8) {
    throw py::value_error("image too large (shape " + ShapeText(a) + ")");
  }
  GrayInput in;
  in.array = py::array::ensure(a, py::array::c_style);  // a copy only when not C-contiguous
  const int h = static_cast<int>(in.array.shape(0));
  const int w = static_cast<int>(in.array.shape(1));
  const int c = grey2d ? 1 : static_cast<int>(in.array.shape(2));
  const auto* data = static_cast<const std::uint8_t*>(in.array.data());
  if (c == 1) {
    in.view = GrayImageView{data, w, h, w};
    return in;
  }
  const cv::Mat src(h, w, CV_8UC(c), const_cast<std::uint8_t*>(data));
  const bool rgb = channels == "rgb";
  const int code = c == 3 ? (rgb ? cv::COLOR_RGB2GRAY : cv::COLOR_BGR2GRAY)
                          : (rgb ? cv::COLOR_RGBA2GRAY : cv::COLOR_BGRA2GRAY);
  cv::cvtColor(src, in.converted, code);
  in.view = GrayImageView{in.converted.data, w, h, static_cast<std::ptrdiff_t>(in.converted.step[0])};
  return in;
}

py::array_t<std::uint8_t> ToNumpy(const GrayImageView& v) {
  py::array_t<std::uint8_t> out({v.height, v.width});
  auto* dst = out.mutable_data();
  for (int y = 0; y < v.height; ++y) {
    std::memcpy(dst + static_cast<std::size_t>(y) * v.width, v.row(y), v.width);
  }
  return out;
}

/// A 3x3 curr_from_prev from a 2x3 or 3x3 array-like; ValueError otherwise.
Eigen::Matrix3d ToTransform(py::handle h, const char* what) {
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(h);
  } catch (const py::error_already_set&) {
    a = {};
  }
  if (!a || a.ndim() != 2 || a.shape(1) != 3 || (a.shape(0) != 2 && a.shape(0) != 3)) {
    throw py::value_error(std::string(what) + " must be a 2x3 or 3x3 array of numbers");
  }
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  for (int r = 0; r < a.shape(0); ++r) {
    for (int c = 0; c < 3; ++c) {
      m(r, c) = a.at(r, c);
      if (!std::isfinite(m(r, c))) throw py::value_error(std::string(what) + " must be finite");
    }
  }
  return m;
}

// ------------------------------------------------------------------------------------------
// Features

py::array_t<Keypoint> KeypointArray(const std::vector<Keypoint>& kps) {
  py::array_t<Keypoint> out(static_cast<py::ssize_t>(kps.size()));
  if (!kps.empty()) std::memcpy(out.mutable_data(), kps.data(), kps.size() * sizeof(Keypoint));
  return out;
}

py::array_t<float> DescriptorArray(const FeatureSet& f) {
  py::array_t<float> out({static_cast<py::ssize_t>(f.size()),
                          static_cast<py::ssize_t>(f.descriptor_size)});
  if (!f.descriptors.empty()) {
    std::memcpy(out.mutable_data(), f.descriptors.data(), f.descriptors.size() * sizeof(float));
  }
  return out;
}

/// Surf with the lock that serialises calls from several Python threads.
struct PySurf {
  explicit PySurf(const SurfOptions& o) : surf(o) {}
  Surf surf;
  std::mutex mutex;
};

SurfResult RunSurf(PySurf& s, const GrayInput& in, double steered) {
  py::gil_scoped_release release;
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.surf.DetectAndDescribe(in.view, steered);
}

// ------------------------------------------------------------------------------------------
// Correspondence

struct PyStage {
  explicit PyStage(const CorrespondenceOptions& o) : stage(o) {}
  CorrespondenceStage stage;
  std::mutex mutex;
};

/// aerovo.correspondence(): a CorrespondenceResult with the two frames' features.
struct CorrespondencePair : CorrespondenceResult {
  FeatureSet prev_features, curr_features;
};

const char* MethodName(CorrespondenceMethod m) {
  return options::EnumName(m);
}

// ------------------------------------------------------------------------------------------
// Odometry

struct PyOdometry {
  explicit PyOdometry(const OdometryOptions& o) : vo(o) {}
  VisualOdometry vo;
  std::mutex mutex;
};

py::dict FrameResultDict(const FrameResult& r) {
  py::dict d;
  d["index"] = r.index;
  d["time_s"] = r.time_s;
  d["status"] = ToString(r.status);
  d["failure"] = ToString(r.failure);
  d["reference_index"] = r.reference_index;
  d["n_surf"] = r.n_surf;
  d["n_matched"] = r.n_matched;
  d["n_inliers"] = r.n_inliers;
  d["cluster"] = r.cluster;
  d["attempts"] = r.attempts;
  d["fell_back"] = r.fell_back;
  d["guided"] = r.guided;
  d["relocalized"] = r.relocalized;
  d["detect_ms"] = r.detect_ms;
  d["describe_ms"] = r.describe_ms;
  d["correspond_ms"] = r.correspond_ms;
  d["estimate_ms"] = r.estimate_ms;
  d["total_ms"] = r.total_ms;
  d["curr_from_prev"] = py::cast(Eigen::Matrix3d(r.curr_from_prev));
  d["world_from_frame"] = py::cast(Eigen::Matrix3d(r.world_from_frame));
  d["position_m"] = py::cast(Eigen::Vector2d(r.position_m));
  d["heading_rad"] = r.heading_rad;
  d["gsd_m_per_px"] = r.gsd_m_per_px;
  d["step_scale"] = r.step_scale;
  return d;
}

// ------------------------------------------------------------------------------------------
// Run folders

py::object JsonToPython(const nlohmann::json& j) {
  if (j.is_null()) return py::none();
  return py::module_::import("json").attr("loads")(j.dump());
}

template <class T, class F>
py::array_t<T> Column(const std::vector<RunFrameRow>& rows, F get) {
  py::array_t<T> out(static_cast<py::ssize_t>(rows.size()));
  T* p = out.mutable_data();
  for (std::size_t i = 0; i < rows.size(); ++i) p[i] = get(rows[i]);
  return out;
}

py::dict ReadRun(const std::filesystem::path& dir) {
  RunData run;
  {
    py::gil_scoped_release release;
    run = ReadRunDir(dir);
  }
  const auto& f = run.frames;
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  py::dict frames;
  frames["frame"] = Column<std::int32_t>(f, [](const RunFrameRow& r) { return r.frame; });
  frames["time_s"] = Column<double>(f, [](const RunFrameRow& r) { return r.time_s; });
  frames["x_m"] = Column<double>(f, [](const RunFrameRow& r) { return r.x_m; });
  frames["y_m"] = Column<double>(f, [](const RunFrameRow& r) { return r.y_m; });
  frames["lat_deg"] = Column<double>(f, [&](const RunFrameRow& r) { return r.geo ? r.geo->lat_deg : kNaN; });
  frames["lon_deg"] = Column<double>(f, [&](const RunFrameRow& r) { return r.geo ? r.geo->lon_deg : kNaN; });
  frames["alt_m"] = Column<double>(  // NaN also when the altitude is not known
      f, [&](const RunFrameRow& r) { return r.geo && r.geo_alt_known ? r.geo->alt_m : kNaN; });
  frames["n_surf"] = Column<std::int32_t>(f, [](const RunFrameRow& r) { return r.n_surf; });
  frames["n_matched"] = Column<std::int32_t>(f, [](const RunFrameRow& r) { return r.n_matched; });
  frames["n_inliers"] = Column<std::int32_t>(f, [](const RunFrameRow& r) { return r.n_inliers; });
  frames["cluster"] = Column<std::int32_t>(f, [](const RunFrameRow& r) { return r.cluster; });
  frames["detect_ms"] = Column<double>(f, [](const RunFrameRow& r) { return r.detect_ms; });
  frames["describe_ms"] = Column<double>(f, [](const RunFrameRow& r) { return r.describe_ms; });
  frames["correspond_ms"] = Column<double>(f, [](const RunFrameRow& r) { return r.correspond_ms; });
  frames["estimate_ms"] = Column<double>(f, [](const RunFrameRow& r) { return r.estimate_ms; });
  frames["total_ms"] = Column<double>(f, [](const RunFrameRow& r) { return r.total_ms; });
  py::list status;
  for (const RunFrameRow& r : f) status.append(r.status);
  frames["status"] = py::module_::import("numpy").attr("array")(status, "str");
  frames["gps_lat_deg"] = Column<double>(f, [&](const RunFrameRow& r) { return r.gps ? r.gps->lat_deg : kNaN; });
  frames["gps_lon_deg"] = Column<double>(f, [&](const RunFrameRow& r) { return r.gps ? r.gps->lon_deg : kNaN; });
  frames["gps_alt_m"] = Column<double>(f, [&](const RunFrameRow& r) { return r.gps ? r.gps->alt_m : kNaN; });

  py::dict transforms;
  const auto n = static_cast<py::ssize_t>(run.transforms.size());
  py::array_t<std::int32_t> tf_frame(n);
  py::array_t<double> tf({n, py::ssize_t{2}, py::ssize_t{3}});
  auto tf_m = tf.mutable_unchecked<3>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const FrameTransformRow& row = run.transforms[static_cast<std::size_t>(i)];
    tf_frame.mutable_data()[i] = row.frame;
    for (int k = 0; k < 6; ++k) tf_m(i, k / 3, k % 3) = row.a[static_cast<std::size_t>(k)];
  }
  transforms["frame"] = tf_frame;
  transforms["first_px_from_frame"] = tf;

  py::dict out;
  out["dir"] = run.dir.string();
  out["frames"] = frames;
  out["transforms"] = transforms;
  out["summary"] = JsonToPython(run.summary);
  out["config"] = JsonToPython(run.config);
  return out;
}

}  // namespace
}  // namespace aerovo::python

PYBIND11_MODULE(aerovo, m) {
  using namespace aerovo;
  using namespace aerovo::python;
  m.doc() =
      "aerovo: visual odometry for UAVs (SURF, clustered RANSAC, VisualOdometry) on numpy "
      "images. Images are uint8 arrays, (h, w) grey or (h, w, 3|4) colour (channels='rgb' "
      "or 'bgr'). See docs/python.md.";
  m.attr("__version__") = kVersion;
  PYBIND11_NUMPY_DTYPE(Keypoint, x, y, scale, orientation, response, laplacian, octave);

  // InvalidArgument is a std::invalid_argument: pybind11 raises ValueError for it.
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);
  // A sibling of InputError (core/error.h), not a kind of it.
  py::register_exception<OutputError>(m, "OutputError", PyExc_OSError);

  // ---- options, from the schema
  auto surf_opts = BindOptions<SurfOptions>(
      m, "SurfOptions",
      "Options of SURF (features/surf.h; MATLAB detectSURFFeatures defaults). Every field of "
      "the option schema is an attribute; plus roi.");
  surf_opts.def_property(
      "roi",
      [](const SurfOptions& o) -> py::object {
        if (!o.roi) return py::none();
        return py::make_tuple(o.roi->x, o.roi->y, o.roi->width, o.roi->height);
      },
      [](SurfOptions& o, py::object v) {
        if (v.is_none()) {
          o.roi.reset();
          return;
        }
        const auto t = v.cast<std::vector<int>>();
        if (t.size() != 4 || t[2] <= 0 || t[3] <= 0) {
          throw py::value_error("SurfOptions.roi must be None or (x, y, width, height) in pixels "
                                "with width, height > 0");
        }
        o.roi = RectI{t[0], t[1], t[2], t[3]};
      },
      "Keep only keypoints whose centre lies in (x, y, width, height), pixels; None = whole image.");
  AddExtraName<SurfOptions>("roi");
  surf_opts.def("validate", [](const SurfOptions& o) { Validate(o); },
                "Raises ValueError naming the field when the options are inconsistent.");
  BindOptions<MatchOptions>(m, "MatchOptions", "Descriptor matching options (matching/matcher.h).");
  BindOptions<RansacOptions>(m, "RansacOptions", "RANSAC options (estimation/ransac.h).");
  BindOptions<ClusteredRansacOptions>(
      m, "ClusteredRansacOptions", "The paper's clustered RANSAC (correspondence/correspondence.h).");
  BindOptions<CorrespondenceOptions>(
      m, "CorrespondenceOptions",
      "Options of the correspondence stage: method, model, sampler, min_inliers, "
      "guided_matching and the nested match, ransac and clustered options.")
      .def("validate", [](const CorrespondenceOptions& o) { Validate(o); },
           "Raises ValueError naming the field when the options are inconsistent.");
  auto odo_opts = BindOptions<OdometryOptions>(
      m, "OdometryOptions",
      "Options of VisualOdometry (odometry/visual_odometry.h): the nested surf and "
      "correspondence options (the odometry's defaults: adaptive SURF, guided matching, ...), "
      "the schema's fields, plus focal_px and default_height_m.");
  odo_opts.def_property(
      "focal_px", [](const OdometryOptions& o) { return o.focal_px; },
      [](OdometryOptions& o, py::handle v) {
        o.focal_px = FieldFromPython<double>(v, "OdometryOptions.focal_px", options::AtLeast(0).Finite());
      },
      "Focal length in pixels of the frames given to process(); 0 = unknown (positions in pixels "
      "of the first frame) (float, finite and >= 0)");
  AddExtraName<OdometryOptions>("focal_px");
  odo_opts.def_property(
      "default_height_m", [](const OdometryOptions& o) { return o.default_height_m; },
      [](OdometryOptions& o, py::handle v) {
        o.default_height_m =
            FieldFromPython<double>(v, "OdometryOptions.default_height_m", options::AtLeast(0).Finite());
      },
      "Height above ground (m) used when process() is given none; 0 = none (float, finite and >= 0)");
  AddExtraName<OdometryOptions>("default_height_m");
  odo_opts.def("validate", [](const OdometryOptions& o) { Validate(o); },
               "Raises ValueError naming the field when the options are inconsistent.");

  // ---- images
  m.def(
      "to_gray",
      [](py::handle image, const std::string& channels) {
        const GrayInput in = ToGray(image, channels);
        return ToNumpy(in.view);
      },
      py::arg("image"), py::arg("channels") = "rgb",
      "The grey uint8 image every function computes on: a 2-D image as it is, colour through "
      "cv::cvtColor (0.299 R + 0.587 G + 0.114 B, fixed point), as aerovo's readers.");
  m.def(
      "read_image",
      [](const std::filesystem::path& path) {
        cv::Mat g;
        {
          py::gil_scoped_release release;
          g = ReadGrayImage(path, GrayFrom::kColor);
        }
        return ToNumpy(GrayImageView{g.data, g.cols, g.rows, static_cast<std::ptrdiff_t>(g.step[0])});
      },
      py::arg("path"),
      "An image file (JPEG, PNG, TIFF) as a grey uint8 array, as `aerovo correspondence` and "
      "the frame sources read it (decoded as colour, then grey). Raises aerovo.InputError naming "
      "the file when it is missing, cut short or not an image.");

  // ---- features
  py::class_<FeatureSet>(m, "Features",
                         "Keypoints and descriptors of one image (features/keypoint.h).")
      .def_property_readonly(
          "keypoints", [](const FeatureSet& f) { return KeypointArray(f.keypoints); },
          "Structured array (copy), strongest first: x, y (pixels, (0, 0) = centre of the "
          "top-left pixel, x right, y down), scale (pixels), orientation (radians, image frame), "
          "response (Hessian determinant), laplacian (+1 dark blob, -1 bright), octave.")
      .def_property_readonly("descriptors", &DescriptorArray,
                             "(N, 64 or 128) float32 array (copy), rows L2-normalised.")
      .def_property_readonly(
          "xy",
          [](const FeatureSet& f) {
            py::array_t<float> out({static_cast<py::ssize_t>(f.size()), py::ssize_t{2}});
            auto o = out.mutable_unchecked<2>();
            for (std::size_t i = 0; i < f.size(); ++i) {
              o(static_cast<py::ssize_t>(i), 0) = f.keypoints[i].x;
              o(static_cast<py::ssize_t>(i), 1) = f.keypoints[i].y;
            }
            return out;
          },
          "(N, 2) float32 array of keypoint positions x, y (pixels).")
      .def_readonly("descriptor_size", &FeatureSet::descriptor_size)
      .def("__len__", &FeatureSet::size)
      .def("__repr__", [](const FeatureSet& f) {
        return "<aerovo.Features: " + std::to_string(f.size()) + " keypoints, " +
               std::to_string(f.descriptor_size) + "-value descriptors>";
      });

  py::class_<SurfResult>(m, "SurfResult", "Result of one SURF call (features/surf.h).")
      .def_readonly("features", &SurfResult::features)
      .def_property_readonly("keypoints", [](const SurfResult& r) { return KeypointArray(r.features.keypoints); },
                             "features.keypoints")
      .def_property_readonly("descriptors", [](const SurfResult& r) { return DescriptorArray(r.features); },
                             "features.descriptors")
      .def_readonly("detect_ms", &SurfResult::detect_ms)
      .def_readonly("describe_ms", &SurfResult::describe_ms)
      .def_readonly("candidates", &SurfResult::candidates)
      .def_readonly("contrast_range", &SurfResult::contrast_range)
      .def_readonly("floor_response", &SurfResult::floor_response)
      .def_readonly("next_min_response", &SurfResult::next_min_response)
      .def("__len__", [](const SurfResult& r) { return r.features.size(); });

  py::class_<PySurf>(m, "Surf",
                     "Reusable SURF engine (keeps its buffers between images of one size).")
      .def(py::init([](py::object options, py::kwargs kwargs) {
             return new PySurf(MakeOptions<SurfOptions>(options, kwargs, "SurfOptions"));
           }),
           py::arg("options") = py::none(),
           "Surf(options=None, **kwargs): a SurfOptions and/or its attributes as keywords.")
      .def_property_readonly("options", [](PySurf& s) { return s.surf.options(); },
                             "A copy of the engine's options.")
      .def(
          "detect_and_describe",
          [](PySurf& s, py::handle image, double steered_min_response, const std::string& channels) {
            const GrayInput in = ToGray(image, channels);
            return RunSurf(s, in, steered_min_response);
          },
          py::arg("image"), py::arg("steered_min_response") = 0.0, py::arg("channels") = "rgb",
          "Keypoints and descriptors of one image (GIL released).");
  m.def(
      "surf",
      [](py::handle image, py::object options, const std::string& channels, py::kwargs kwargs) {
        PySurf s(MakeOptions<SurfOptions>(options, kwargs, "SurfOptions"));
        const GrayInput in = ToGray(image, channels);
        return RunSurf(s, in, 0.0);
      },
      py::arg("image"), py::arg("options") = py::none(), py::arg("channels") = "rgb",
      "SURF on one image: surf(image, options=None, channels='rgb', **surf_options) -> "
      "SurfResult (keypoints, descriptors as numpy arrays). E.g. "
      "aerovo.surf(img, hessian_threshold=500, upright=True).");

  // ---- correspondence
  py::class_<CorrespondenceResult>(
      m, "CorrespondenceResult",
      "Result of the correspondence stage for one frame pair (correspondence/correspondence.h).")
      .def_readonly("success", &CorrespondenceResult::success)
      .def_property_readonly(
          "curr_from_prev", [](const CorrespondenceResult& r) { return Eigen::Matrix3d(r.curr_from_prev); },
          "3x3 transform from prev pixels to curr pixels (identity when not success).")
      .def_property_readonly(
          "matches",
          [](const CorrespondenceResult& r) {
            py::array_t<std::int32_t> out({static_cast<py::ssize_t>(r.matches.size()), py::ssize_t{2}});
            auto o = out.mutable_unchecked<2>();
            for (std::size_t i = 0; i < r.matches.size(); ++i) {
              o(static_cast<py::ssize_t>(i), 0) = r.matches[i].prev_index;
              o(static_cast<py::ssize_t>(i), 1) = r.matches[i].curr_index;
            }
            return out;
          },
          "(N, 2) int32: indices into the prev and curr keypoints of the matches the transform "
          "was fitted to.")
      .def_property_readonly(
          "match_ssd",
          [](const CorrespondenceResult& r) {
            py::array_t<float> out(static_cast<py::ssize_t>(r.matches.size()));
            for (std::size_t i = 0; i < r.matches.size(); ++i) out.mutable_data()[i] = r.matches[i].ssd;
            return out;
          },
          "(N,) float32: squared descriptor distance of each match.")
      .def_property_readonly(
          "inlier_mask",
          [](const CorrespondenceResult& r) {
            py::array_t<bool> out(static_cast<py::ssize_t>(r.inlier_mask.size()));
            for (std::size_t i = 0; i < r.inlier_mask.size(); ++i) out.mutable_data()[i] = r.inlier_mask[i] != 0;
            return out;
          },
          "(N,) bool: True for the RANSAC inliers among matches.")
      .def_readonly("num_inliers", &CorrespondenceResult::num_inliers)
      .def_property_readonly("method_used", [](const CorrespondenceResult& r) { return MethodName(r.method_used); })
      .def_readonly("fell_back", &CorrespondenceResult::fell_back)
      .def_readonly("cell_row", &CorrespondenceResult::cell_row)
      .def_readonly("cell_col", &CorrespondenceResult::cell_col)
      .def_readonly("attempts", &CorrespondenceResult::attempts)
      .def_readonly("refined", &CorrespondenceResult::refined)
      .def_readonly("final_pass", &CorrespondenceResult::final_pass)
      .def_readonly("refine_shift_px", &CorrespondenceResult::refine_shift_px)
      .def_property_readonly("crop", [](const CorrespondenceResult& r) {
        return py::make_tuple(r.crop.x, r.crop.y, r.crop.width, r.crop.height);
      }, "(x, y, width, height) of the prev frame kept (clustered), pixels.")
      .def_readonly("cell_point_counts", &CorrespondenceResult::cell_point_counts)
      .def_readonly("ransac_trials", &CorrespondenceResult::ransac_trials)
      .def_readonly("num_comparisons", &CorrespondenceResult::num_comparisons)
      .def_readonly("match_ms", &CorrespondenceResult::match_ms)
      .def_readonly("estimate_ms", &CorrespondenceResult::estimate_ms)
      .def_readonly("total_ms", &CorrespondenceResult::total_ms);
  py::class_<CorrespondencePair, CorrespondenceResult>(
      m, "CorrespondencePair", "aerovo.correspondence()'s result: a CorrespondenceResult with "
      "the two images' features.")
      .def_readonly("prev_features", &CorrespondencePair::prev_features)
      .def_readonly("curr_features", &CorrespondencePair::curr_features);

  const auto optional_transform = [](const py::object& t, const char* what) {
    std::optional<Eigen::Matrix3d> out;
    if (!t.is_none()) out = ToTransform(t, what);
    return out;
  };
  py::class_<PyStage>(m, "CorrespondenceStage",
                      "The correspondence stage with its reusable buffers: match two frames' "
                      "features and fit curr_from_prev.")
      .def(py::init([](py::object options, py::kwargs kwargs) {
             return new PyStage(MakeOptions<CorrespondenceOptions>(options, kwargs, "CorrespondenceOptions"));
           }),
           py::arg("options") = py::none())
      .def_property_readonly("options", [](PyStage& s) { return s.stage.options(); },
                             "A copy of the stage's options.")
      .def(
          "run",
          [optional_transform](PyStage& s, const FeatureSet& prev, const FeatureSet& curr, int prev_width,
                               int prev_height, py::object last_curr_from_prev) {
            const auto last = optional_transform(last_curr_from_prev, "last_curr_from_prev");
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(s.mutex);
            return s.stage.Run(prev, prev_width, prev_height, curr, last);
          },
          py::arg("prev"), py::arg("curr"), py::arg("prev_width"), py::arg("prev_height"),
          py::arg("last_curr_from_prev") = py::none(),
          "options.method on prev -> curr; last_curr_from_prev: the previous step's transform "
          "(None: the first pair, zero motion assumed).")
      .def(
          "standard",
          [optional_transform](PyStage& s, const FeatureSet& prev, const FeatureSet& curr, py::object prior) {
            const auto p = optional_transform(prior, "prior");
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(s.mutex);
            return s.stage.Standard(prev, curr, p);
          },
          py::arg("prev"), py::arg("curr"), py::arg("prior") = py::none(),
          "The standard method: all points matched, RANSAC on all matches.")
      .def(
          "clustered",
          [](PyStage& s, const FeatureSet& prev, const FeatureSet& curr, int prev_width, int prev_height,
             py::object last_curr_from_prev) {
            const Eigen::Matrix3d last = last_curr_from_prev.is_none()
                                             ? Eigen::Matrix3d::Identity()
                                             : ToTransform(last_curr_from_prev, "last_curr_from_prev");
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(s.mutex);
            return s.stage.Clustered(prev, prev_width, prev_height, curr, last);
          },
          py::arg("prev"), py::arg("curr"), py::arg("prev_width"), py::arg("prev_height"),
          py::arg("last_curr_from_prev") = py::none(),
          "The paper's clustered RANSAC (None: identity, zero motion).");
  m.def(
      "correspondence",
      [optional_transform](py::handle prev_image, py::handle curr_image, py::object options,
                           py::object surf_options, py::object last_curr_from_prev,
                           const std::string& channels, py::kwargs kwargs) {
        const CorrespondenceOptions co =
            MakeOptions<CorrespondenceOptions>(options, kwargs, "CorrespondenceOptions");
        const SurfOptions so = MakeOptions<SurfOptions>(surf_options, py::kwargs(), "SurfOptions");
        const auto last = optional_transform(last_curr_from_prev, "last_curr_from_prev");
        const GrayInput prev = ToGray(prev_image, channels);
        const GrayInput curr = ToGray(curr_image, channels);
        CorrespondencePair out;
        py::gil_scoped_release release;
        Validate(so);
        Surf surf(so);
        out.prev_features = surf.DetectAndDescribe(prev.view).features;
        out.curr_features = surf.DetectAndDescribe(curr.view).features;
        CorrespondenceStage stage(co);
        static_cast<CorrespondenceResult&>(out) =
            stage.Run(out.prev_features, prev.view.width, prev.view.height, out.curr_features, last);
        return out;
      },
      py::arg("prev_image"), py::arg("curr_image"), py::arg("options") = py::none(),
      py::arg("surf_options") = py::none(), py::arg("last_curr_from_prev") = py::none(),
      py::arg("channels") = "rgb",
      "SURF on both images, then the correspondence stage (default: the paper's clustered "
      "RANSAC, affine): correspondence(prev, curr, options=None, surf_options=None, "
      "last_curr_from_prev=None, channels='rgb', **correspondence_options) -> "
      "CorrespondencePair (success, curr_from_prev 3x3, matches, inlier_mask, features).");

  // ---- odometry
  py::class_<FrameResult>(m, "FrameResult",
                          "What VisualOdometry.process did with one frame "
                          "(odometry/visual_odometry.h; frames: odometry/pose_chain.h).")
      .def_readonly("index", &FrameResult::index)
      .def_readonly("time_s", &FrameResult::time_s)
      .def_property_readonly("status", [](const FrameResult& r) { return ToString(r.status); },
                             "'first', 'ok', 'reacquired' or 'bridged'.")
      .def_property_readonly("failure", [](const FrameResult& r) { return ToString(r.failure); },
                             "Why a bridged step failed ('' otherwise).")
      .def_readonly("reference_index", &FrameResult::reference_index)
      .def_readonly("n_surf", &FrameResult::n_surf)
      .def_readonly("n_matched", &FrameResult::n_matched)
      .def_readonly("n_inliers", &FrameResult::n_inliers)
      .def_readonly("cluster", &FrameResult::cluster)
      .def_readonly("attempts", &FrameResult::attempts)
      .def_readonly("fell_back", &FrameResult::fell_back)
      .def_readonly("guided", &FrameResult::guided)
      .def_readonly("relocalized", &FrameResult::relocalized)
      .def_readonly("total_ms", &FrameResult::total_ms)
      .def_property_readonly("curr_from_prev", [](const FrameResult& r) { return Eigen::Matrix3d(r.curr_from_prev); },
                             "3x3 step applied: reference frame's pixels -> this frame's pixels.")
      .def_property_readonly("world_from_frame", [](const FrameResult& r) { return Eigen::Matrix3d(r.world_from_frame); },
                             "3x3: this frame's pixels -> local metres (metric mode).")
      .def_property_readonly("position_m", [](const FrameResult& r) { return Eigen::Vector2d(r.position_m); },
                             "Camera centre (x, y) in metres, x = first image right, y = first image up.")
      .def_readonly("heading_rad", &FrameResult::heading_rad)
      .def_readonly("gsd_m_per_px", &FrameResult::gsd_m_per_px)
      .def_readonly("step_scale", &FrameResult::step_scale)
      .def("to_dict", &FrameResultDict, "Every field as a dict.")
      .def("__repr__", [](const FrameResult& r) {
        return "<aerovo.FrameResult " + std::to_string(r.index) + " " + ToString(r.status) +
               ": x " + std::to_string(r.position_m.x()) + " m, y " +
               std::to_string(r.position_m.y()) + " m>";
      });

  py::class_<PyOdometry>(m, "VisualOdometry",
                         "The streaming visual odometry: process() one frame at a time.")
      .def(py::init([](py::object options, py::kwargs kwargs) {
             return new PyOdometry(MakeOptions<OdometryOptions>(options, kwargs, "OdometryOptions"));
           }),
           py::arg("options") = py::none(),
           "VisualOdometry(options=None, **kwargs), e.g. VisualOdometry(focal_px=1000, "
           "default_height_m=100).")
      .def_property_readonly("options", [](PyOdometry& o) { return o.vo.options(); },
                             "A copy of the odometry's options.")
      .def(
          "process",
          [](PyOdometry& o, py::handle image, double time_s, std::optional<double> height_m,
             std::optional<double> yaw_deg, const std::string& channels) {
            const GrayInput in = ToGray(image, channels);
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(o.mutex);
            return o.vo.Process(in.view, time_s, height_m, yaw_deg);
          },
          py::arg("image"), py::arg("time_s"), py::arg("height_m") = py::none(),
          py::arg("yaw_deg") = py::none(), py::arg("channels") = "rgb",
          "The next frame: time_s (s), height_m above ground (else options.default_height_m), "
          "yaw_deg (only with heading_from_yaw) -> FrameResult. Raises aerovo.InputError when "
          "the frame size changes or no height is known.")
      .def_property_readonly(
          "stats",
          [](PyOdometry& o) {
            const OdometryStats& s = o.vo.stats();
            py::dict d;
            d["frames"] = s.frames;
            d["ok"] = s.ok;
            d["reacquired"] = s.reacquired;
            d["bridged"] = s.bridged;
            return d;
          },
          "Counts over the frames processed: frames, ok, reacquired, bridged.");

  // ---- run folders
  m.def("read_run", &ReadRun, py::arg("dir"),
        "A run folder of `aerovo run` as arrays: {'dir', 'frames': {column: numpy array} "
        "(frames.csv; NaN where a position is absent), 'transforms': {'frame', "
        "'first_px_from_frame' (N, 2, 3)}, 'summary': dict or None, 'config': dict or None}. "
        "Raises aerovo.InputError naming the file and line for a bad or missing frames.csv.");
}
