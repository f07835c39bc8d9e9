#include "aerovo/report/html_report.h"
#include "aerovo/core/text.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <ostream>
#include <regex>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "aerovo/core/error.h"
#include "aerovo/core/statistics.h"
#include "aerovo/core/timer.h"
#include "aerovo/eval/trajectory_eval_json.h"
#include "aerovo/geo/local_enu.h"
#include "aerovo/outputs/track_writers.h"
#include "aerovo/report/experiment_kind.h"
#include "aerovo/report/geo_mosaic.h"
#include "aerovo/report/html_builder.h"
#include "aerovo/report/leaflet_assets.h"
#include "aerovo/report/run_reader.h"
#include "aerovo/report/style.h"

namespace aerovo {
namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// "a/b/" -> "b": the folder's own name for titles.
std::string DirName(const fs::path& dir) {
  fs::path d = dir.lexically_normal();
  if (d.filename().empty()) d = d.parent_path();
  const std::string name = d.filename().string();
  return name.empty() || name == "." ? fs::absolute(dir).lexically_normal().string() : name;
}

// ---------------------------------------------------------------------------------------------
// Text helpers

std::string Base64(const std::string& data) {
  static const char* const kAlphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < data.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(data[i]) << 16) |
                       (static_cast<unsigned char>(data[i + 1]) << 8) |
                       static_cast<unsigned char>(data[i + 2]);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < data.size()) {
    unsigned v = static_cast<unsigned char>(data[i]) << 16;
    if (i + 1 < data.size()) v |= static_cast<unsigned char>(data[i + 1]) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < data.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string ReadFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw InputError("cannot read '" + p.string() + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A gnuplot SVG made fit for inlining in HTML: no XML declaration or DOCTYPE (the DTD URL),
// no namespace attributes (the HTML parser puts <svg> in the SVG namespace by itself), and ids
// prefixed so that several figures in one page do not share ids.
std::string InlineSvg(const fs::path& svg_file, const std::string& prefix) {
  std::string s = ReadFile(svg_file);
  const std::size_t start = s.find("<svg");
  if (start == std::string::npos) throw InputError("'" + svg_file.string() + "' holds no <svg>");
  s = s.substr(start);
  static const std::regex xmlns(R"(\s+xmlns(:\w+)?\s*=\s*("[^"]*"|'[^']*'))");
  s = std::regex_replace(s, xmlns, "");
  static const std::regex id(R"(\bid=(["']))");
  s = std::regex_replace(s, id, "id=$1" + prefix);
  static const std::regex href(R"(href=(["'])#)");
  s = std::regex_replace(s, href, "href=$1#" + prefix);
  static const std::regex url(R"(url\(#)");
  s = std::regex_replace(s, url, "url(#" + prefix);
  const std::size_t open_end = s.find('>');
  s.insert(open_end, " class=\"figure-svg\" preserveAspectRatio=\"xMidYMid meet\"");
  return s;
}

std::string Num(double v, int decimals = 2) {
  if (!std::isfinite(v)) return "–";
  return fmt::format("{:.{}f}", v, decimals);
}

std::string JsonCell(const nlohmann::json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_null()) return "";
  if (v.is_number_float()) {
    const double d = v.get<double>();
    if (d == std::floor(d) && std::abs(d) < 1e15) return fmt::format("{:.1f}", d);
    return fmt::format("{:.6g}", d);
  }
  return v.dump();
}

double JsonNumber(const nlohmann::json& j, std::initializer_list<const char*> path,
                  double fallback = kNaN) {
  const nlohmann::json* cur = &j;
  for (const char* key : path) {
    if (!cur->is_object() || !cur->contains(key)) return fallback;
    cur = &(*cur)[key];
  }
  return cur->is_number() ? cur->get<double>() : fallback;
}

std::string JsonString(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_string()) return "";
  return j[key].get<std::string>();
}

// ---------------------------------------------------------------------------------------------
// The page

struct Page {
  std::string title;
  HtmlBuilder body;  // the page's content, between the <h1> and the self-check script
  int figures = 0;   // <svg> figures and <img> expected to render
  std::string head;  // more of <head>: the map's Leaflet CSS and JS when the page has a map

  void H2(const std::string& text, const std::string& id = "") {
    body.Element("h2", id.empty() ? HtmlBuilder::Attributes{} : HtmlBuilder::Attributes{{"id", id}},
                 text)
        .Newline();
  }
  /// A paragraph of markup (`html` is HTML, not text).
  void Para(const std::string& html) { body.Open("p").Raw(html).Close("p").Newline(); }
  /// A paragraph of markup built with HtmlBuilder.
  void Para(const HtmlBuilder& html) { Para(html.str()); }
  void Note(const std::string& text) { body.Element("p", {{"class", "note"}}, text).Newline(); }
  void Table(const std::vector<std::string>& header,
             const std::vector<std::vector<std::string>>& rows, const std::string& cls = "") {
    body.Open("table",
              cls.empty() ? HtmlBuilder::Attributes{} : HtmlBuilder::Attributes{{"class", cls}})
        .Newline();
    if (!header.empty()) {
      body.Open("thead").Open("tr");
      for (const std::string& h : header) body.Element("th", {}, h);
      body.Close("tr").Close("thead").Newline();
    }
    body.Open("tbody").Newline();
    for (const auto& r : rows) {
      body.Open("tr");
      for (std::size_t i = 0; i < r.size(); ++i) {
        if (i == 0) {
          body.Element("th", {{"scope", "row"}}, r[i]);
        } else {
          body.Element("td", {}, r[i]);
        }
      }
      body.Close("tr").Newline();
    }
    body.Close("tbody").Close("table").Newline();
  }

  std::string Html() const {
    std::string h;
    h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
    h += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
    h += "<meta name=\"generator\" content=\"aerovo report\">\n";
    // Offline by construction: the browser refuses any request for anything not in the page
    // (scripts, styles and images inline or data: URIs; links to figures/ are navigations, not
    // requests of the page). A refused request is recorded (securitypolicyviolation) for the
    // self-check below: data-blocked-requests.
    h += "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src "
         "data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'\">\n";
    h += "<script>window.aerovoBlocked=[];document.addEventListener('securitypolicyviolation',"
         "function(e){window.aerovoBlocked.push(e.blockedURI||e.violatedDirective);});</script>\n";
    h += HtmlBuilder().Element("title", {}, title).str() + "\n<style>\n";
    h +=
        R"(body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;margin:0 auto;max-width:1280px;padding:1em 2em;color:#1b1b1b;background:#fff}
h1{font-size:1.6em;margin-bottom:.2em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}th,td{border:1px solid #d0d0d0;padding:.25em .6em;text-align:right}
thead th{background:#f0f3f7;text-align:center}tbody th{text-align:left;font-weight:normal;background:#fafafa}
table.summary td{text-align:left}table.kv td{text-align:left;font-family:ui-monospace,"DejaVu Sans Mono",monospace}
figure{margin:1em 0;padding:.5em;border:1px solid #e3e3e3;border-radius:4px}
figure.plot svg{display:block;width:100%;max-width:1000px;height:auto;margin:0 auto}
figure.image img{display:block;max-width:100%;height:auto;margin:0 auto}
figcaption{font-size:.9em;color:#444;margin-top:.3em;text-align:center}
.note{background:#fff7e0;border-left:4px solid #e6a800;padding:.4em .8em}
.meta{color:#555;font-size:.9em}nav a{margin-right:1em}
.answer{font-size:1.1em;background:#eef5fb;border-left:4px solid #555;padding:.6em 1em}
.explain{font-size:.92em;color:#333;max-width:60em}
#aerovo-map{height:560px;width:100%;background:#f2f1ec;border:1px solid #d0d0d0}
.map-legend{font-size:.9em}.map-legend span{display:inline-block;width:1.6em;height:.35em;vertical-align:middle;margin:0 .3em 0 1em}
)";
    h += "</style>\n" + head + "</head>\n";
    h += fmt::format("<body data-figures-expected=\"{}\">\n", figures);
    h += HtmlBuilder().Element("h1", {}, title).Newline().str();
    h += body.str();
    // Self-check for headless browsers (report_browser_test): each figure laid out with a
    // non-zero size and drawn, each image decoded.
    h += R"(<script>
(function () {
  function check() {
    var ok = 0, failed = [];
    document.querySelectorAll('figure.plot').forEach(function (f) {
      var s = f.querySelector('svg');
      var r = s ? s.getBoundingClientRect() : null;
      if (r && r.width > 0 && r.height > 0 && s.querySelector('path')) ok++; else failed.push(f.id);
    });
    document.querySelectorAll('figure.image img').forEach(function (i) {
      if (i.complete && i.naturalWidth > 0 && i.getBoundingClientRect().width > 0) ok++;
      else failed.push(i.id);
    });
    document.body.setAttribute('data-figures-ok', String(ok));
    document.body.setAttribute('data-figures-failed', failed.join(' '));
    document.body.setAttribute('data-blocked-requests', String(window.aerovoBlocked.length));
    document.body.setAttribute('data-blocked-urls', window.aerovoBlocked.join(' '));
    // The map (when the page has one): its tracks as SVG paths, the mosaic overlay decoded,
    // the scale bar, where it lies on the page, and the hover text of its middle VO frame.
    var el = document.getElementById('aerovo-map');
    if (el) {
      var vertices = function (cls) {
        var p = el.querySelector('path.' + cls);
        var m = p ? (p.getAttribute('d') || '').match(/[ML]/g) : null;
        return String(m ? m.length : 0);
      };
      var b = document.body, r = el.getBoundingClientRect(), m = window.aerovoMap;
      b.setAttribute('data-map-ready', m ? '1' : '0');
      b.setAttribute('data-map-vo-vertices', vertices('aerovo-vo'));
      b.setAttribute('data-map-gps-vertices', vertices('aerovo-gps'));
      var img = el.querySelector('img.leaflet-image-layer');
      b.setAttribute('data-map-overlay', img && img.complete && img.naturalWidth > 0 ? '1' : '0');
      var scale = el.querySelector('.leaflet-control-scale-line');
      b.setAttribute('data-map-scale', scale ? scale.textContent : '');
      b.setAttribute('data-map-rect', [r.left + window.scrollX, r.top + window.scrollY, r.width,
                                       r.height].map(Math.round).join(','));
      if (m && m.data.vo.length > 0) {
        var k = Math.floor(m.data.vo.length / 2);
        b.setAttribute('data-map-hover', m.text(k));
      }
    }
  }
  check();
  window.addEventListener('load', check);
})();
</script>
)";
    h += "</body>\n</html>\n";
    return h;
  }
};

// A note shown on the page and returned in ReportResult::notes.
void AddNote(Page& page, ReportResult& result, const std::string& text) {
  page.Note(text);
  result.notes.push_back(text);
}

// Renders `figure` into DIR/figures and inlines it in the page.
class FigureSink {
 public:
  FigureSink(const fs::path& dir, const ReportOptions& options, Page& page, ReportResult& result)
      : dir_(dir), options_(options), page_(page), result_(result) {}

  void Add(const Figure& figure, const std::string& caption) {
    PlotOptions po = options_.plot;
    po.svg = true;  // the HTML inlines the SVG
    const FigureFiles files = RenderFigure(figure, dir_ / ReportFileNames::kFiguresDir, po);
    result_.figures.push_back(files.svg);
    if (!files.png.empty()) result_.figures.push_back(files.png);
    const std::string rel = std::string(ReportFileNames::kFiguresDir) + "/" + figure.name;
    HtmlBuilder& b = page_.body;
    b.Open("figure", {{"class", "plot"}, {"id", "fig-" + figure.name}}).Newline();
    b.Raw(InlineSvg(files.svg, figure.name + "-")).Newline();
    b.Open("figcaption").Text(caption + " — ").Element("a", {{"href", rel + ".svg"}}, "SVG");
    if (!files.png.empty()) b.Text(" · ").Element("a", {{"href", rel + ".png"}}, "PNG");
    b.Text(" · ").Element("a", {{"href", rel + ".gp"}}, "gnuplot script").Close("figcaption");
    b.Newline().Close("figure").Newline();
    ++page_.figures;
    if (options_.log) *options_.log << "  figure " << files.svg.string() << "\n";
  }

  void Note(const std::string& text) { AddNote(page_, result_, text); }

  void AddImage(const fs::path& file, const std::string& id, const std::string& caption) {
    std::string ext = file.extension().string();
    const std::string mime = (ext == ".png") ? "image/png" : "image/jpeg";
    const std::string rel =
        std::string(ReportFileNames::kFiguresDir) + "/" + file.filename().string();
    const std::string src = "data:" + mime + ";base64," + Base64(ReadFile(file));
    HtmlBuilder& b = page_.body;
    b.Open("figure", {{"class", "image"}})
        .Open("img", {{"id", id}, {"alt", caption}, {"src", src}});
    b.Newline().Open("figcaption").Text(caption + " — ");
    b.Element("a", {{"href", rel}}, file.filename().string()).Close("figcaption").Close("figure");
    b.Newline();
    ++page_.figures;
  }

 private:
  fs::path dir_;
  const ReportOptions& options_;
  Page& page_;
  ReportResult& result_;
};

// ---------------------------------------------------------------------------------------------
// Run folder

PlotSeries Series(std::string title, std::vector<double> x, std::vector<double> y,
                  SeriesStyle style = SeriesStyle::kLines, std::string color = "") {
  PlotSeries s;
  s.title = std::move(title);
  s.x = std::move(x);
  s.y = std::move(y);
  s.style = style;
  s.color = std::move(color);
  return s;
}

// VO positions of every frame mapped by `t` (x, y of the frames.csv rows).
void AlignedTrack(const RunData& run, const Similarity2D& t, std::vector<double>* x,
                  std::vector<double>* y) {
  for (const RunFrameRow& f : run.frames) {
    const Eigen::Vector2d p = t.Apply({f.x_m, f.y_m});
    x->push_back(p.x());
    y->push_back(p.y());
  }
}

std::vector<double> FrameAxis(const RunData& run) {
  std::vector<double> x;
  for (const RunFrameRow& f : run.frames) x.push_back(f.frame);
  return x;
}

template <class Get>
std::vector<double> Column(const RunData& run, Get get, bool positive_only = false) {
  std::vector<double> y;
  for (const RunFrameRow& f : run.frames) {
    const double v = get(f);
    y.push_back(positive_only && !(v > 0.0) ? kNaN : v);
  }
  return y;
}

// Index of the correspond series in StageTimesFigure.
constexpr std::size_t kStageTimesCorrespond = 2;

// Time of each stage per frame of `run` (log scale): detect, describe, correspond (at
// kStageTimesCorrespond), estimate and the whole frame (black), milliseconds; frames without a
// time (0) are left out.
Figure StageTimesFigure(const RunData& run, const std::string& name, const std::string& title) {
  Figure f;
  f.name = name;
  f.title = title;
  f.x_label = "frame";
  f.y_label = "time (ms)";
  f.log_y = true;
  f.key = "outside right top";
  const std::vector<double> x = FrameAxis(run);
  struct Stage {
    const char* name;
    double RunFrameRow::*ms;
  };
  for (const Stage& st :
       {Stage{"detect", &RunFrameRow::detect_ms}, Stage{"describe", &RunFrameRow::describe_ms},
        Stage{"correspond", &RunFrameRow::correspond_ms},
        Stage{"estimate", &RunFrameRow::estimate_ms}}) {
    f.series.push_back(Series(st.name, x,
                              Column(
                                  run, [&](const RunFrameRow& r) { return r.*st.ms; }, true)));
  }
  f.series.push_back(Series("total", x,
                            Column(
                                run, [](const RunFrameRow& r) { return r.total_ms; }, true),
                            SeriesStyle::kLines, style::Hex(style::kStart)));
  return f;
}

// Summary numbers from summary.json, or recomputed from frames.csv when the run was killed
// before writing it.
nlohmann::json EffectiveSummary(const RunData& run, const RunComparison& cmp) {
  if (run.summary.is_object()) return run.summary;
  nlohmann::json s;
  int ok = 0, reacquired = 0, bridged = 0, with_gps = 0;
  double sums[5] = {0, 0, 0, 0, 0};
  double path = 0.0;
  for (std::size_t i = 0; i < run.frames.size(); ++i) {
    const RunFrameRow& f = run.frames[i];
    if (f.status.rfind("ok", 0) == 0 || f.status.rfind("first", 0) == 0) ++ok;
    if (f.status.rfind("reacquired", 0) == 0) ++reacquired;
    if (f.status.rfind("bridged", 0) == 0) ++bridged;
    if (f.gps) ++with_gps;
    sums[0] += f.detect_ms;
    sums[1] += f.describe_ms;
    sums[2] += f.correspond_ms;
    sums[3] += f.estimate_ms;
    sums[4] += f.total_ms;
    if (i > 0) {
      path += std::hypot(f.x_m - run.frames[i - 1].x_m, f.y_m - run.frames[i - 1].y_m);
    }
  }
  const double n = std::max<std::size_t>(1, run.frames.size());
  s["input"] = JsonString(run.config, "input");
  s["frames_processed"] = run.frames.size();
  s["frames_ok"] = ok;
  s["frames_reacquired"] = reacquired;
  s["frames_bridged"] = bridged;
  s["frames_with_gps"] = with_gps;
  s["interrupted"] = true;
  s["vo_path_length_m"] = path;
  s["mean_stage_ms"] = {{"detect", sums[0] / n},
                        {"describe", sums[1] / n},
                        {"correspond", sums[2] / n},
                        {"estimate", sums[3] / n},
                        {"total", sums[4] / n}};
  s["evaluation"] = cmp.comparison ? ToJson(*cmp.comparison) : nlohmann::json();
  s["recomputed"] = true;
  return s;
}

// SE(2) / Sim(2) columns of a TrajectoryComparison JSON (eval/trajectory_eval_json.h).
void EvaluationTable(Page& page, const nlohmann::json& ev) {
  std::vector<std::vector<std::string>> e;
  auto row = [&](const std::string& label, std::initializer_list<const char*> path, int dec) {
    std::vector<std::string> r{label};
    for (const char* model : {"se2", "sim2"}) {
      if (!ev.contains(model)) {
        r.push_back("–");
        continue;
      }
      const nlohmann::json* cur = &ev[model];
      double v = kNaN;
      bool found = true;
      for (const char* k : path) {
        if (!cur->is_object() || !cur->contains(k)) {
          found = false;
          break;
        }
        cur = &(*cur)[k];
      }
      if (found && cur->is_number()) v = cur->get<double>();
      if (found && cur->is_array() && cur->size() == 2) {
        r.push_back(Num((*cur)[0].get<double>(), dec) + ", " + Num((*cur)[1].get<double>(), dec));
        continue;
      }
      r.push_back(Num(v, dec));
    }
    e.push_back(r);
  };
  row("Pairs (frames with a reference)", {"alignment", "num_points"}, 0);
  row("Distance flown (reference, m)", {"distance_flown_m"}, 1);
  row("Alignment rotation (deg)", {"alignment", "rotation_deg"}, 3);
  row("Alignment scale", {"alignment", "scale"}, 5);
  row("ATE RMSE (m)", {"ate_m", "rmse"}, 2);
  row("ATE RMSE (% of distance)", {"ate_rmse_percent"}, 3);
  row("ATE mean (m)", {"ate_m", "mean"}, 2);
  row("ATE median (m)", {"ate_m", "median"}, 2);
  row("ATE max (m)", {"ate_m", "max"}, 2);
  row("End-point error (m)", {"end_point_error_m"}, 2);
  row("End-point error (%)", {"end_point_error_percent"}, 3);
  row("End-point error, no alignment (m)", {"end_point_error_unaligned_m"}, 2);
  row("End-point error, no alignment (%)", {"end_point_error_unaligned_percent"}, 3);
  if (ev.contains("se2") && ev.contains("sim2") && ev["se2"].contains("segments") &&
      ev["sim2"].contains("segments") &&
      ev["se2"]["segments"].size() == ev["sim2"]["segments"].size()) {
    for (std::size_t i = 0; i < ev["se2"]["segments"].size(); ++i) {
      const double len = JsonNumber(ev["se2"]["segments"][i], {"length_m"});
      std::vector<std::string> r{
          fmt::format("Relative error over {:.0f} m: mean drift (%), n", len)};
      for (const char* model : {"se2", "sim2"}) {
        const nlohmann::json& seg = ev[model]["segments"][i];
        r.push_back(Num(JsonNumber(seg, {"drift_percent", "mean"}), 2) +
                    " %, n = " + Num(JsonNumber(seg, {"drift_percent", "count"}), 0));
      }
      e.push_back(r);
    }
  }
  page.Table({"", "SE(2)", "Sim(2)"}, e);
}

// An error for a reader: 2 decimals under 10 (m or %), 1 above.
std::string Metres(double v) { return Num(v, std::abs(v) < 10.0 ? 2 : 1); }

// The answer a pilot looks for first, in one paragraph: frames tracked, distance flown, end
// error and ATE against GPS.
void AnswerBox(Page& page, const nlohmann::json& s) {
  const double processed = JsonNumber(s, {"frames_processed"}, 0);
  const double ok = JsonNumber(s, {"frames_ok"}, 0) + JsonNumber(s, {"frames_reacquired"}, 0);
  const double bridged = JsonNumber(s, {"frames_bridged"}, 0);
  HtmlBuilder a;
  a.Element("strong", {}, fmt::format("Tracked {:.0f} of {:.0f} frames", ok, processed));
  if (bridged > 0) a.Text(fmt::format(" ({:.0f} bridged with the previous motion)", bridged));
  const nlohmann::json none;
  const nlohmann::json& ev = s.contains("evaluation") ? s["evaluation"] : none;
  if (ev.is_object() && ev.contains("se2")) {
    const nlohmann::json& e = ev["se2"];
    a.Text(fmt::format(" over {} m flown (GPS). ", Num(JsonNumber(e, {"distance_flown_m"}), 0)));
    a.Element("strong", {},
              fmt::format("End error against GPS: {} m ({} % of the distance)",
                          Metres(JsonNumber(e, {"end_point_error_m"})),
                          Metres(JsonNumber(e, {"end_point_error_percent"}))));
    a.Text(fmt::format(
        " after the SE(2) alignment, {} m as geo-referenced (no alignment); ATE RMSE {} m.",
        Metres(JsonNumber(e, {"end_point_error_unaligned_m"})),
        Metres(JsonNumber(e, {"ate_m", "rmse"}))));
    const nlohmann::json& o = s.contains("optimized") ? s["optimized"] : none;
    if (o.is_object() && o.contains("evaluation") && o["evaluation"].is_object()) {
      const nlohmann::json& oe = o["evaluation"];
      a.Text(fmt::format(
          " Optimised after the flight (vo_optimized.*): ATE RMSE {} m SE(2), {} m Sim(2), "
          "against {} m and {} m for the causal track.",
          Metres(JsonNumber(oe, {"se2", "ate_m", "rmse"})),
          Metres(JsonNumber(oe, {"sim2", "ate_m", "rmse"})),
          Metres(JsonNumber(e, {"ate_m", "rmse"})),
          Metres(JsonNumber(ev, {"sim2", "ate_m", "rmse"}))));
    }
  } else {
    const std::string note = s.contains("gps_comparison_note") &&
                                     s["gps_comparison_note"].is_string() &&
                                     !s["gps_comparison_note"].get<std::string>().empty()
                                 ? s["gps_comparison_note"].get<std::string>()
                                 : std::string("fewer than 3 frames with a fix");
    a.Text(fmt::format(", VO path {} m. No comparison with GPS ({}).",
                       Num(JsonNumber(s, {"vo_path_length_m"}), 0), note));
  }
  if (s.value("interrupted", false)) a.Text(" The run was interrupted.");
  page.body.Open("p", {{"class", "answer"}, {"id", "answer"}}).Raw(a.str()).Close("p").Newline();
}

// What the comparison's numbers mean (eval/trajectory_eval.h), beside the table; `ev` its
// evaluation JSON, to say which case this run is.
void ExplainEvaluation(Page& page, const nlohmann::json& ev) {
  const double se2_ate = JsonNumber(ev, {"se2", "ate_m", "rmse"});
  const double sim2_ate = JsonNumber(ev, {"sim2", "ate_m", "rmse"});
  const double se2_end = JsonNumber(ev, {"se2", "end_point_error_m"});
  const double sim2_end = JsonNumber(ev, {"sim2", "end_point_error_m"});
  const double scale = JsonNumber(ev, {"sim2", "alignment", "scale"});
  std::string h =
      "<div class=\"explain\"><p><strong>How to read it.</strong> ATE (absolute "
      "trajectory error) is the RMS, over every frame with a reference position, of "
      "the distance between the aligned VO position and the reference; the end-point "
      "error is that distance at the last frame only. SE(2) aligns by a rotation and "
      "a translation and trusts VO's metric scale (from height and focal length); "
      "Sim(2) may also scale the track. ";
  h += "Because Sim(2) has one more degree of freedom to minimise the RMS, its ATE is never "
       "higher than SE(2)'s; but the least-squares fit spreads the error over the whole flight, "
       "so the scale that best fits the middle of the track can move its end further away: "
       "<em>a lower Sim(2) ATE with a higher Sim(2) end error is expected</em>, not a fault.";
  if (std::isfinite(sim2_ate) && std::isfinite(se2_ate) && std::isfinite(sim2_end) &&
      std::isfinite(se2_end) && sim2_ate <= se2_ate && sim2_end > se2_end) {
    h += fmt::format(" This run is such a case (ATE {} m vs {} m, end error {} m vs {} m).",
                     Num(sim2_ate), Num(se2_ate), Num(sim2_end), Num(se2_end));
  }
  if (std::isfinite(scale)) {
    h += fmt::format(
        " The Sim(2) scale ({}) is the factor by which VO's metric scale is off: "
        "far from 1 (e.g. beyond 0.95-1.05), suspect the height or the focal length.",
        Num(scale, 3));
  }
  h += "</p><p><strong>Relative error over L m</strong> (drift): from every frame, the segment "
       "ends where the reference has flown L m further; the error is the difference between "
       "VO's and the reference's displacement over that segment (after the alignment's "
       "rotation and scale; offsets cancel), in per cent of L. It measures local accuracy, "
       "wherever the error accumulated. Over short segments GPS noise dominates: a fix 1 m "
       "off alone makes 10 % over 10 m, so a large drift over 10 m with a small drift over "
       "100 m is GPS noise, not VO.</p></div>\n";
  page.body.Raw(h);  // literal markup and numbers
}

// The causal and the optimised track's figures side by side: `causal` and `optimised` are two
// evaluation JSONs (summary.json "evaluation" and "optimized"."evaluation", or the truth's).
void SideBySideTable(Page& page, const nlohmann::json& causal, const nlohmann::json& optimised) {
  std::vector<std::vector<std::string>> rows;
  const nlohmann::json none;
  const auto at = [&none](const nlohmann::json& ev, const char* model) -> const nlohmann::json& {
    return ev.is_object() && ev.contains(model) ? ev[model] : none;
  };
  const auto row = [&](const std::string& label, const char* model,
                       std::initializer_list<const char*> path) {
    rows.push_back({label, Metres(JsonNumber(at(causal, model), path)),
                    Metres(JsonNumber(at(optimised, model), path))});
  };
  row("ATE RMSE, SE(2)-aligned (m)", "se2", {"ate_m", "rmse"});
  row("ATE RMSE, Sim(2)-aligned (m)", "sim2", {"ate_m", "rmse"});
  row("End-point error, SE(2)-aligned (m)", "se2", {"end_point_error_m"});
  row("End-point error, no alignment (m)", "se2", {"end_point_error_unaligned_m"});
  page.Table({"", "causal (vo.*)", "optimised (vo_optimized.*)"}, rows);
}

// The offline whole-flight optimisation's track (summary.json "optimized", vo_optimized.*):
// what it did, its figures beside the causal track's, then the same comparisons as the causal
// track's.
void OptimizedTables(Page& page, const nlohmann::json& s) {
  const nlohmann::json& o = s["optimized"];
  page.H2("Offline optimisation", "optimized");
  page.Para(fmt::format(
      "After the last frame, keyframes whose footprints overlap were matched again and the "
      "whole track optimised with them (docs/backend.md; vo_optimized.*): {:.0f} keyframes, "
      "{:.0f} pairs tried, {:.0f} verified, {:.0f} rejected ({:.0f} by the gate against the "
      "track), {:.0f} down-weighted by the robust cost; {:.2f} s of CPU.",
      JsonNumber(o, {"keyframes"}, 0), JsonNumber(o, {"pairs_tried"}, 0),
      JsonNumber(o, {"pairs_verified"}, 0), JsonNumber(o, {"pairs_rejected"}, 0),
      JsonNumber(o, {"pairs_gated"}, 0), JsonNumber(o, {"outliers"}, 0),
      JsonNumber(o, {"cpu_s"}, 0)));
  for (const auto& [key, name] : {std::pair<const char*, const char*>{"evaluation", "GPS"},
                                  {"truth_evaluation", "the ground truth"}}) {
    if (!o.contains(key) || !o[key].is_object()) continue;
    if (s.contains(key) && s[key].is_object()) {
      page.Para(std::string("Both tracks against ") + name + ":");
      SideBySideTable(page, s[key], o[key]);
    }
    page.Para(std::string("The optimised track against ") + name +
              ", aligned as the causal one above:");
    EvaluationTable(page, o[key]);
  }
}

// GPS denial (summary.json "gps_denied"; docs/map.md): the track against the withheld fixes,
// unaligned, over time since the denial.
void DeniedTable(Page& page, const nlohmann::json& d) {
  page.H2("Without GPS", "gps-denied");
  const nlohmann::json& e = d.contains("error") ? d["error"] : d;
  if (!e.is_object() || !e.contains("end_error_m")) {
    page.Para("GPS denied after " + Num(JsonNumber(d, {"after_s"}, 0), 1) +
              " s: no error against the withheld GPS (" + JsonString(d, "note") + ").");
    return;
  }
  page.Para(fmt::format(
      "GPS withheld from frame {:.0f} ({:.1f} s) on (docs/map.md): the geo-referenced track "
      "against the withheld fixes, not aligned.",
      JsonNumber(d, {"from_frame"}, 0), JsonNumber(d, {"from_time_s"}, 0)));
  std::vector<std::vector<std::string>> rows;
  rows.push_back({"at the denial", Num(JsonNumber(e, {"first_error_m"}, 0), 2), "0"});
  if (e.contains("at") && e["at"].is_array()) {
    for (const auto& a : e["at"]) {
      rows.push_back({fmt::format("after {:.0f} min", JsonNumber(a, {"after_s"}, 0) / 60.0),
                      Num(JsonNumber(a, {"error_m"}, 0), 2), Num(JsonNumber(a, {"distance_m"}, 0), 0)});
    }
  }
  rows.push_back({"at the end", Num(JsonNumber(e, {"end_error_m"}, 0), 2),
                  Num(JsonNumber(e, {"distance_m"}, 0), 0)});
  rows.push_back({"RMSE / max", Num(JsonNumber(e, {"rmse_m"}, 0), 2) + " / " +
                                    Num(JsonNumber(e, {"max_error_m"}, 0), 2), ""});
  if (e.contains("end_error_per_km_m") && e["end_error_per_km_m"].is_number()) {
    rows.push_back({"end error per km without GPS",
                    Num(e["end_error_per_km_m"].get<double>(), 2), "1000"});
  }
  page.Table({"", "error (m)", "flown without GPS (m)"}, rows, "summary");
}

// The comparisons with GPS and the ground truth, with their explanation.
void ComparisonTables(Page& page, const nlohmann::json& s) {
  const nlohmann::json none;
  const nlohmann::json& ev = s.contains("evaluation") ? s["evaluation"] : none;
  if (ev.is_object()) {
    page.H2("Comparison with GPS", "comparison");
    page.Para(
        "Local East-North-Up metres, origin at the first accepted GPS fix; the VO track is "
        "aligned to GPS by a rigid SE(2) motion (the metric scale is trusted) and, for reference, by a "
        "Sim(2) similarity (Umeyama).");
    EvaluationTable(page, ev);
    ExplainEvaluation(page, ev);
  }
  if (s.contains("truth_evaluation") && s["truth_evaluation"].is_object()) {
    page.H2("Comparison with the ground truth", "truth");
    page.Para(HtmlBuilder()
                  .Text("Against ")
                  .Element("code", {}, JsonString(s, "truth"))
                  .Text(" (frames matched by time), aligned as above."));
    EvaluationTable(page, s["truth_evaluation"]);
  }
  if (s.contains("gps_denied") && s["gps_denied"].is_object()) DeniedTable(page, s["gps_denied"]);
  if (s.contains("optimized") && s["optimized"].is_object()) OptimizedTables(page, s);
}

// The run's details, then its timings (after the accuracy).
void DetailsTables(Page& page, const nlohmann::json& s) {
  std::vector<std::vector<std::string>> rows;
  rows.push_back({"Input", JsonString(s, "input")});
  if (!JsonString(s, "source").empty()) rows.push_back({"Source", JsonString(s, "source")});
  const bool interrupted = s.value("interrupted", false);
  rows.push_back(
      {"Frames processed", fmt::format("{:.0f}{}", JsonNumber(s, {"frames_processed"}, 0),
                                       interrupted ? " (interrupted)" : "")});
  rows.push_back(
      {"  ok / re-acquired / bridged",
       fmt::format("{:.0f} / {:.0f} / {:.0f}", JsonNumber(s, {"frames_ok"}, 0),
                   JsonNumber(s, {"frames_reacquired"}, 0), JsonNumber(s, {"frames_bridged"}, 0))});
  rows.push_back({"Frames with GPS", fmt::format("{:.0f}", JsonNumber(s, {"frames_with_gps"}, 0))});
  rows.push_back({"VO path length (m)", Num(JsonNumber(s, {"vo_path_length_m"}), 1)});
  if (s.contains("focal_px")) {
    rows.push_back({"Focal length (px)", Num(JsonNumber(s, {"focal_px"}), 1) + " (" +
                                             JsonString(s, "focal_source") + ")"});
    rows.push_back({"Height source", JsonString(s, "height_source")});
    rows.push_back({"Heading source", JsonString(s, "heading_source")});
  }
  page.H2("Summary", "summary");
  if (s.value("recomputed", false)) {
    page.Note(
        "summary.json is missing (the run was stopped before its end): figures recomputed "
        "from frames.csv.");
  }
  page.Table({"", "value"}, rows, "summary");

  std::vector<std::vector<std::string>> times;
  for (const char* stage : {"detect", "describe", "correspond", "estimate", "total"}) {
    times.push_back({std::string("Mean ") + stage + " time (ms)",
                     Num(JsonNumber(s, {"mean_stage_ms", stage}), 2)});
  }
  if (s.contains("fps")) {
    times.push_back({"Throughput (frames/s)", Num(JsonNumber(s, {"fps"}), 2) + " (" +
                                                  Num(JsonNumber(s, {"wall_s"}), 1) + " s)"});
  }
  page.H2("Timings", "timings");
  page.Table({"", "value"}, times, "summary");
}

void FlattenJson(const nlohmann::json& j, const std::string& prefix,
                 std::vector<std::vector<std::string>>* rows) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = prefix.empty() ? it.key() : prefix + "." + it.key();
    if (it->is_object()) {
      FlattenJson(*it, key, rows);
    } else {
      rows->push_back({key, it->is_string() ? it->get<std::string>() : it->dump()});
    }
  }
}

// The frame centres of a run in first-frame pixels and the similarity from the VO positions (ENU)
// to those pixels, fitted once per run report and shared by every track drawn on the mosaic.
struct FramePixels {
  std::vector<Eigen::Vector2d> centres_px;  // FrameCentresPx(run)
  // Sim(2) fitted between the VO positions and the frame centres; pixels have y down, so it is
  // fitted against (u, -v). None with fewer than 3 frames with a centre, or when the fit fails.
  std::optional<Similarity2D> px_from_enu;
};

FramePixels FitFramePixels(const RunData& run) {
  FramePixels out;
  std::vector<int> frames;
  out.centres_px = FrameCentresPx(run, &frames);
  std::map<int, Eigen::Vector2d> centre_of;
  for (std::size_t i = 0; i < frames.size(); ++i) centre_of[frames[i]] = out.centres_px[i];
  std::vector<TrajectoryPoint2D> enu, px;
  for (const RunFrameRow& f : run.frames) {
    const auto it = centre_of.find(f.frame);
    if (it == centre_of.end()) continue;
    enu.push_back({f.time_s, f.x_m, f.y_m});
    px.push_back({f.time_s, it->second.x(), -it->second.y()});
  }
  if (enu.size() < 3) return out;
  try {
    out.px_from_enu = AlignUmeyama2D(enu, px, AlignmentModel::kSim2).enu_from_vo;
  } catch (const InvalidArgument&) {
    // degenerate (e.g. every frame at one place): the reference tracks are left off the mosaic
  }
  return out;
}

// The reference track (GPS or ground truth) in the first frame's pixels: GPS (ENU) -> VO ENU
// through the inverse of the SE(2) alignment, then VO ENU -> pixels through
// `pixels.px_from_enu`. Empty when either is missing.
std::vector<Eigen::Vector2d> GpsInFirstFramePixels(const FramePixels& pixels,
                                                   const RunComparison& cmp) {
  std::vector<Eigen::Vector2d> out;
  if (!cmp.comparison || !pixels.px_from_enu) return out;
  const Similarity2D& a = cmp.comparison->se2.alignment.enu_from_vo;
  for (const TrajectoryPoint2D& g : cmp.reference) {
    const Eigen::Vector2d vo =
        a.Rotation().transpose() * (Eigen::Vector2d(g.x, g.y) - a.translation_m) / a.scale;
    const Eigen::Vector2d p = pixels.px_from_enu->Apply(vo);
    out.emplace_back(p.x(), -p.y());
  }
  return out;
}

// A map (equal axes) gets the height that fits its data's aspect: no empty bands above and below.
void FitMapHeight(Figure& f) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const PlotSeries& s : f.series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  }
  if (!(x1 > x0) || !(y1 > y0)) return;
  const double aspect = (y1 - y0) / (x1 - x0);
  double plot_width_px = f.width_px - 360.0;  // key outside on the right, margins
  if (plot_width_px * aspect > 730.0) {       // tall: narrower, not taller than 900 px
    plot_width_px = 730.0 / aspect;
    f.width_px = static_cast<int>(std::max(560.0, plot_width_px + 360.0));
  }
  const double h = plot_width_px * aspect + 170.0;  // title, labels
  f.height_px = static_cast<int>(std::clamp(h, 360.0, 900.0));
}

// A map of tracks in east/north metres (the run's or the ground truth's ENU frame), equal axes,
// the key outside; FitMapHeight sets the height once the tracks are in.
Figure MapFigure(const std::string& name) {
  Figure f;
  f.name = name;
  f.x_label = "east (m)";
  f.y_label = "north (m)";
  f.equal_axes = true;
  f.key = "outside right top";
  f.width_px = 1000;
  f.height_px = 700;
  return f;
}

// The colour of `cmp`'s reference track (style.h): GPS or a ground truth.
std::string ReferenceColour(const RunComparison& cmp) {
  return style::Hex(cmp.reference_name == "GPS" ? style::kGps : style::kTruth);
}

// Marks at the bridged frames of `run` (their VO positions mapped by `t`), when there are any.
void BridgedMarks(const RunData& run, const Similarity2D& t, Figure& f) {
  std::vector<double> x, y;
  for (const RunFrameRow& r : run.frames) {
    if (r.status.rfind("bridged", 0) != 0) continue;
    const Eigen::Vector2d p = t.Apply({r.x_m, r.y_m});
    x.push_back(p.x());
    y.push_back(p.y());
  }
  if (x.empty()) return;
  f.series.push_back(Series(fmt::format("bridged frames ({})", x.size()), x, y,
                            SeriesStyle::kPoints, style::Hex(style::kBridged)));
  f.series.back().point_size = 0.8;
}

// Fig. 2: the VO track against `cmp`'s reference after its SE(2) (and Sim(2)) alignment.
void TrajectoryFigure(const RunData& run, const RunComparison& cmp, const std::string& name,
                      FigureSink& sink) {
  Figure f = MapFigure(name);
  if (cmp.comparison) {
    const TrajectoryComparison& c = *cmp.comparison;
    std::vector<double> gx, gy;
    for (const TrajectoryPoint2D& p : cmp.reference) {
      gx.push_back(p.x);
      gy.push_back(p.y);
    }
    f.series.push_back(
        Series(cmp.reference_name, gx, gy, SeriesStyle::kLinesPoints, ReferenceColour(cmp)));
    f.series.back().point_size = 0.35;
    f.series.back().line_width = 1.0;
    std::vector<double> x, y;
    AlignedTrack(run, c.se2.alignment.enu_from_vo, &x, &y);
    f.series.push_back(
        Series("VO, SE(2)-aligned", x, y, SeriesStyle::kLines, style::Hex(style::kVo)));
    f.series.back().line_width = 2.0;
    x.clear();
    y.clear();
    AlignedTrack(run, c.sim2.alignment.enu_from_vo, &x, &y);
    f.series.push_back(
        Series("VO, Sim(2)-aligned", x, y, SeriesStyle::kLines, style::Hex(style::kVoSim2)));
    f.series.back().dashed = true;
    f.series.push_back(Series("start", {gx.front()}, {gy.front()}, SeriesStyle::kPoints,
                              style::Hex(style::kStart)));
    f.series.back().point_size = 1.5;
    BridgedMarks(run, c.se2.alignment.enu_from_vo, f);
    f.title = fmt::format(
        "Fig. 2: VO trajectory against {} (local ENU; ATE RMSE SE(2) {:.2f} m, Sim(2) {:.2f} m "
        "over {:.0f} m)",
        cmp.reference_name, c.se2.ate_m.rmse, c.sim2.ate_m.rmse, c.se2.distance_flown_m);
  } else {
    std::vector<double> x, y;
    AlignedTrack(run, Similarity2D{}, &x, &y);
    f.series.push_back(Series("VO", x, y, SeriesStyle::kLines, style::Hex(style::kVo)));
    BridgedMarks(run, Similarity2D{}, f);
    f.title = "Fig. 2: VO trajectory (no " + cmp.reference_name + " to compare with)";
    const bool geo = !run.frames.empty() && run.frames.back().geo.has_value();
    if (!geo) {  // not geo-referenced: the local VO frame (odometry/pose_chain.h)
      f.x_label = "x, first image right (m)";
      f.y_label = "y, first image up (m)";
    }
    FitMapHeight(f);
    sink.Add(f, "Fig. 2 of the paper: the computed trajectory; no " + cmp.reference_name +
                    " to compare it with.");
    return;
  }
  FitMapHeight(f);
  sink.Add(f, "Fig. 2 of the paper: the computed trajectory against " + cmp.reference_name +
                  ", after the alignment used by the summary.");
}

std::string MapFixKind(const MapFixRow& f);

// The fixes against the reference maps (map_fixes.csv) over the geo-referenced track and GPS as
// the run wrote them (no alignment), in the run's ENU frame (RunEnuFrame), by what became of each
// (MapFixKind), the fixes' error against GPS in the title. Nothing without a drawn fix.
void MapFixesFigure(const RunData& run, FigureSink& sink) {
  const std::optional<LocalEnu> enu = RunEnuFrame(run);
  if (!enu) return;
  Figure f = MapFigure("map_fixes");
  std::vector<double> vx, vy, gx, gy;
  for (const RunFrameRow& r : run.frames) {
    if (r.gps) {
      const Eigen::Vector3d p = enu->Forward(*r.gps);
      gx.push_back(p.x());
      gy.push_back(p.y());
    }
    if (r.geo) {
      const Eigen::Vector3d p = enu->Forward(*r.geo);
      vx.push_back(p.x());
      vy.push_back(p.y());
    }
  }
  if (!gx.empty()) {
    f.series.push_back(Series("GPS", gx, gy, SeriesStyle::kLines, style::Hex(style::kGps)));
    f.series.back().line_width = 4.0;
  }
  f.series.push_back(Series("VO as flown (geo-referenced)", vx, vy, SeriesStyle::kLines,
                            style::Hex(style::kVo)));
  const std::pair<const char*, style::Rgb> kinds[3] = {
      {"fused", style::kMapFixFused}, {"recorded", style::kMapFixRecorded},
      {"gated", style::kMapFixGated}};
  std::vector<double> errors;
  int drawn = 0;
  for (const auto& [kind, colour] : kinds) {
    std::vector<double> x, y;
    for (const MapFixRow& m : run.map_fixes) {
      if (MapFixKind(m) != kind) continue;
      const Eigen::Vector3d p = enu->Forward(*m.geo);
      x.push_back(p.x());
      y.push_back(p.y());
      if (m.gps_error_m && std::string(kind) != "gated") errors.push_back(*m.gps_error_m);
    }
    if (x.empty()) continue;
    drawn += static_cast<int>(x.size());
    const std::string title = std::string(kind) == "fused"      ? "map fixes fused"
                              : std::string(kind) == "recorded" ? "map fixes, not fused"
                                                                : "map fixes rejected by a gate";
    f.series.push_back(Series(fmt::format("{} ({})", title, x.size()), x, y, SeriesStyle::kPoints,
                              style::Hex(colour)));
    f.series.back().point_size = 1.2;
  }
  if (drawn == 0) return;
  f.title = "Fixes against the map over the track";
  if (!errors.empty()) {
    f.title += fmt::format(" (against GPS: median {:.2f} m, max {:.2f} m over {} fixes)",
                           Median(errors), *std::max_element(errors.begin(), errors.end()),
                           errors.size());
  }
  FitMapHeight(f);
  sink.Add(f, "The fixes against the reference map (map_fixes.csv) over the track as the run "
              "wrote it and its GPS (withheld or not), in the local East-North frame: fused into "
              "the track, recorded only, or rejected by a gate.");
}

void RunFigures(const RunData& run, const RunComparison& cmp,
                const std::optional<RunComparison>& truth, FigureSink& sink) {
  TrajectoryFigure(run, cmp, "fig2_trajectory", sink);
  MapFixesFigure(run, sink);
  // Against the ground truth too, when the run was compared with one (aerovo run --truth).
  if (truth && truth->comparison) TrajectoryFigure(run, *truth, "fig2_trajectory_truth", sink);
  const std::vector<double> frames = FrameAxis(run);
  // Fig. 3
  {
    Figure f;
    f.name = "fig3_points";
    f.title = "Fig. 3: SURF points per frame (N_SURF), putative matches, RANSAC inliers";
    f.x_label = "frame";
    f.y_label = "points per frame";
    f.y_from_zero = true;
    f.key = "outside right top";
    f.series.push_back(Series("N_SURF (interest points)", frames,
                              Column(run, [](const RunFrameRow& r) { return r.n_surf; })));
    f.series.push_back(Series("matched points", frames,
                              Column(run, [](const RunFrameRow& r) { return r.n_matched; })));
    f.series.push_back(Series("RANSAC inliers", frames,
                              Column(run, [](const RunFrameRow& r) { return r.n_inliers; })));
    sink.Add(f,
             "Fig. 3 of the paper: the number of interest points on each frame and the number "
             "of points used for the correspondence.");
  }
  // Stage times
  sink.Add(StageTimesFigure(run, "stage_times", "Time of each stage per frame (log scale)"),
           "Per-frame time of SURF detection, SURF description, matching (correspond), "
           "transform estimation (RANSAC) and the whole frame, milliseconds.");
  // Error per frame, against the distance flown and against time
  if (cmp.comparison) {
    std::vector<double> by_frame, by_time, by_distance;
    double flown_m = 0.0;
    for (std::size_t i = 0; i < cmp.row.size(); ++i) {
      const RunFrameRow& r = run.frames[static_cast<std::size_t>(cmp.row[i])];
      by_frame.push_back(r.frame);
      by_time.push_back(r.time_s);
      if (i > 0) {  // the reference's path length, as distance_flown_m (eval/trajectory_eval.h)
        flown_m += std::hypot(cmp.reference[i].x - cmp.reference[i - 1].x,
                              cmp.reference[i].y - cmp.reference[i - 1].y);
      }
      by_distance.push_back(flown_m);
    }
    auto error_figure = [&](const std::string& name, const std::string& x_label,
                            const std::vector<double>& x) {
      Figure f;
      f.name = name;
      f.title = "Position error after alignment (against " + cmp.reference_name + ")";
      f.x_label = x_label;
      f.y_label = "position error (m)";
      f.y_from_zero = true;
      f.series.push_back(Series("VO, SE(2)-aligned", x, cmp.comparison->se2.ate_per_point_m,
                                SeriesStyle::kLines, style::Hex(style::kVo)));
      f.series.push_back(Series("VO, Sim(2)-aligned", x, cmp.comparison->sim2.ate_per_point_m,
                                SeriesStyle::kLines, style::Hex(style::kVoSim2)));
      f.series.back().dashed = true;
      return f;
    };
    const std::string why =
        " The Sim(2) curve can lie below the SE(2) one on average and still end higher: see "
        "\"How to read it\" above.";
    sink.Add(
        error_figure("error_vs_distance",
                     "distance flown (m, " + cmp.reference_name + " path length)", by_distance),
        "Absolute trajectory error against the distance flown, metres: how the error grows "
        "along the flight." +
            why);
    sink.Add(error_figure("error_vs_time", "time (s)", by_time),
             "Absolute trajectory error against the frame's time, metres.");
    sink.Add(error_figure("ate_per_frame", "frame", by_frame),
             "Absolute trajectory error of each frame with a reference position, metres.");
  }
}

// ---------------------------------------------------------------------------------------------
// The interactive map (Leaflet, inlined: leaflet_assets.h)

// Degrees rounded to 1e-7 (~1 cm): short JSON, no precision a track needs lost.
double Deg7(double deg) { return std::round(deg * 1e7) / 1e7; }
double Round3(double v) { return std::round(v * 1e3) / 1e3; }

// leaflet.css with its url(images/NAME) as data: URIs (the page requests nothing).
std::string LeafletCssInline() {
  std::string css(leaflet::Css());
  static const std::regex url(R"(url\(images/([A-Za-z0-9_.-]+)\))");
  std::string out;
  auto begin = css.cbegin();
  for (std::sregex_iterator it(css.begin(), css.end(), url), end; it != end; ++it) {
    out.append(begin, css.cbegin() + it->position());
    const std::string_view bytes = leaflet::Image((*it)[1].str());
    out += bytes.empty() ? std::string("none")
                         : "url(data:image/png;base64," + Base64(std::string(bytes)) + ")";
    begin = css.cbegin() + it->position() + it->length();
  }
  out.append(begin, css.cend());
  return out;
}

// The geo-referenced north-up mosaic of the run (DIR/mosaic_geo.json + its PNG, written by
// `aerovo report`'s geo mosaic) as {"uri", "south", "west", "north", "east"}; null when there is
// none. A malformed file is a note naming it, not an error: the map is drawn without it.
nlohmann::json GeoMosaicOverlay(const fs::path& dir, std::string* note) {
  const fs::path json_path = dir / ReportFileNames::kGeoMosaicJson;
  if (!fs::is_regular_file(json_path)) return nullptr;
  try {
    const nlohmann::json j = nlohmann::json::parse(ReadFile(json_path));
    if (!j.is_object()) throw InputError("not a JSON object");
    nlohmann::json out;
    for (const char* key : {"south", "west", "north", "east"}) {
      if (!j.contains(key) || !j[key].is_number() || !std::isfinite(j[key].get<double>())) {
        throw InputError(std::string("\"") + key + "\" is missing or not a finite number");
      }
      out[key] = j[key].get<double>();
    }
    if (!(out["south"].get<double>() < out["north"].get<double>()) ||
        !(out["west"].get<double>() < out["east"].get<double>()) ||
        out["south"].get<double>() < -90.0 || out["north"].get<double>() > 90.0) {
      throw InputError("the bounds are not south < north, west < east within [-90, 90]");
    }
    const std::string image = JsonString(j, "image");
    if (image.empty() || fs::path(image).has_parent_path() ||
        fs::path(image).extension() != ".png") {
      throw InputError("\"image\" must name a .png file beside it");
    }
    const fs::path png = dir / image;
    const std::string bytes = ReadFile(png);
    if (bytes.size() < 8 || bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0) {
      throw InputError("'" + png.string() + "' is not a PNG file");
    }
    out["uri"] = "data:image/png;base64," + Base64(bytes);
    return out;
  } catch (const std::exception& e) {  // InputError, nlohmann::json::exception
    *note = "geo-referenced mosaic left off the map: '" + json_path.string() + "': " + e.what();
    return nullptr;
  }
}

// What a map fix (map_fixes.csv row) drawn on the map and the figure is: "fused" (a fix fused
// into the track), "recorded" (a fix not fused: --map-fix-apply off), "gated" (the map fix's gate
// or the pose graph's rejected it); "" for an attempt without a position worth drawing.
std::string MapFixKind(const MapFixRow& f) {
  if (!f.geo) return "";
  if (f.status == "gate" || f.gated_by_graph) return "gated";
  if (f.status != "fix") return "";
  return f.applied ? "fused" : "recorded";
}

nlohmann::json MapFixColours() {
  return {{"fused", style::Hex(style::kMapFixFused)},
          {"recorded", style::Hex(style::kMapFixRecorded)},
          {"gated", style::Hex(style::kMapFixGated)}};
}

// The map fixes drawn on the map: [lat, lon, kind, frame, time s, error to GPS m (null without
// GPS), map index (null)] per attempt with a kind (MapFixKind).
nlohmann::json MapFixMarkers(const RunData& run) {
  nlohmann::json out = nlohmann::json::array();
  for (const MapFixRow& f : run.map_fixes) {
    const std::string kind = MapFixKind(f);
    if (kind.empty()) continue;
    out.push_back({Deg7(f.geo->lat_deg), Deg7(f.geo->lon_deg), kind, f.frame, Round3(f.time_s),
                   f.gps_error_m ? nlohmann::json(Round3(*f.gps_error_m)) : nlohmann::json(),
                   f.map ? nlohmann::json(*f.map) : nlohmann::json()});
  }
  return out;
}

// The map's data: lat/lon tracks (VO geo-referenced as frames.csv gives it, GPS fixes, the ground
// truth), per VO point its frame, time, status and error to GPS, the bridged points, colours.
nlohmann::json MapData(const RunData& run, const RunComparison& cmp,
                       const std::optional<RunComparison>& truth) {
  nlohmann::json vo = nlohmann::json::array(), info = nlohmann::json::array(),
                 gps = nlohmann::json::array(), bridged = nlohmann::json::array(),
                 truth_track = nlohmann::json::array();
  // The run's ENU frame: origin at its first accepted fix (RunEnuFrame, odometry/georef.h).
  const std::optional<LocalEnu> enu = RunEnuFrame(run);
  std::map<int, double> se2_error_of_row;
  if (cmp.comparison) {
    for (std::size_t i = 0; i < cmp.row.size(); ++i) {
      se2_error_of_row[cmp.row[i]] = cmp.comparison->se2.ate_per_point_m[i];
    }
  }
  for (std::size_t r = 0; r < run.frames.size(); ++r) {
    const RunFrameRow& f = run.frames[r];
    if (f.gps) gps.push_back({Deg7(f.gps->lat_deg), Deg7(f.gps->lon_deg)});
    if (!f.geo) continue;
    vo.push_back({Deg7(f.geo->lat_deg), Deg7(f.geo->lon_deg)});
    nlohmann::json drawn = nullptr, aligned = nullptr;
    if (f.gps && enu) {
      const Eigen::Vector3d a = enu->Forward(*f.geo), b = enu->Forward(*f.gps);
      drawn = Round3(std::hypot(a.x() - b.x(), a.y() - b.y()));
    }
    if (const auto it = se2_error_of_row.find(static_cast<int>(r)); it != se2_error_of_row.end()) {
      aligned = Round3(it->second);
    }
    info.push_back({f.frame, Round3(f.time_s), f.status, drawn, aligned});
    if (f.status.rfind("bridged", 0) == 0) bridged.push_back(vo.size() - 1);
  }
  // The VO track under the SE(2) alignment of the comparison (a layer shown on demand: the
  // shape of the track against GPS, whatever its heading at the first fix).
  nlohmann::json aligned_track = nlohmann::json::array();
  if (cmp.comparison && enu) {
    const Similarity2D& t = cmp.comparison->se2.alignment.enu_from_vo;
    for (const RunFrameRow& f : run.frames) {
      const Eigen::Vector2d p = t.Apply({f.x_m, f.y_m});
      const GeoPoint g = enu->Reverse(p.x(), p.y(), 0.0);
      aligned_track.push_back({Deg7(g.lat_deg), Deg7(g.lon_deg)});
    }
  }
  // The optimised track (vo_optimized.tum, the run's ENU frame), drawn as the run wrote it.
  nlohmann::json optimized = nlohmann::json::array();
  const bool geo = !run.frames.empty() && run.frames.back().geo.has_value();
  if (geo && enu) {
    for (const TrajectoryPoint2D& p : run.optimized) {
      const GeoPoint g = enu->Reverse(p.x, p.y, 0.0);
      optimized.push_back({Deg7(g.lat_deg), Deg7(g.lon_deg)});
    }
  }
  if (truth && truth->comparison && enu) {
    for (const TrajectoryPoint2D& p : truth->reference) {
      const GeoPoint g = enu->Reverse(p.x, p.y, 0.0);
      truth_track.push_back({Deg7(g.lat_deg), Deg7(g.lon_deg)});
    }
  }
  return {{"vo", vo},
          {"map_fixes", MapFixMarkers(run)},
          {"info", info},
          {"gps", gps},
          {"truth", truth_track},
          {"vo_se2", aligned_track},
          {"vo_optimized", optimized},
          {"bridged", bridged},
          {"colours",
           {{"vo", style::Hex(style::kVo)},
            {"vo_optimized", style::Hex(style::kVoOptimized)},
            {"gps", style::Hex(style::kGps)},
            {"truth", style::Hex(style::kTruth)},
            {"bridged", style::Hex(style::kBridged)},
            {"map_fix", MapFixColours()}}}};
}

// The map's script: reads the JSON of #aerovo-map-data (MapData plus "mosaic"), draws it with
// Leaflet on a plain background (no tiles), fits the tracks, a metric scale bar, a layer switch,
// and on hover the nearest VO frame within 14 px: frame, time, status, error to GPS.
constexpr const char* kMapScript = R"js(
(function () {
  var d = JSON.parse(document.getElementById('aerovo-map-data').textContent);
  var map = L.map('aerovo-map', {zoomSnap: 0.25, maxZoom: 24, attributionControl: false});
  L.control.attribution({prefix: 'Leaflet (BSD-2-Clause)'}).addTo(map);
  L.control.scale({imperial: false, maxWidth: 200}).addTo(map);
  var layers = {};
  if (d.mosaic) {
    layers['mosaic (north-up)'] = L.imageOverlay(d.mosaic.uri,
        [[d.mosaic.south, d.mosaic.west], [d.mosaic.north, d.mosaic.east]]).addTo(map);
  }
  if (d.gps.length) {
    // Widest and underneath, the truth dashed over it, VO thin on top: all three stay visible
    // where they agree.
    layers['GPS'] = L.polyline(d.gps, {color: d.colours.gps, weight: 7, opacity: 1,
                                       className: 'aerovo-gps', interactive: false}).addTo(map);
  }
  if (d.truth.length) {
    layers['ground truth'] = L.polyline(d.truth, {color: d.colours.truth, weight: 4, opacity: 1,
        dashArray: '8 8',
        className: 'aerovo-truth', interactive: false}).addTo(map);
  }
  if (d.vo.length) {
    layers['VO'] = L.polyline(d.vo, {color: d.colours.vo, weight: 2, className: 'aerovo-vo',
                                     interactive: false}).addTo(map);
  }
  if (d.vo_optimized.length) {
    layers['VO optimised (offline)'] = L.polyline(d.vo_optimized, {color: d.colours.vo_optimized,
        weight: 2, className: 'aerovo-vo-optimized', interactive: false}).addTo(map);
  }
  if (d.vo_se2.length) {  // off until ticked
    layers['VO, SE(2)-aligned to GPS'] = L.polyline(d.vo_se2, {color: d.colours.vo, weight: 2,
        dashArray: '6 6', className: 'aerovo-vo-se2', interactive: false});
  }
  if (d.bridged.length) {
    var g = L.layerGroup();
    d.bridged.forEach(function (i) {
      L.circleMarker(d.vo[i], {radius: 3, color: d.colours.bridged, weight: 1, fillOpacity: 0.9,
                               className: 'aerovo-bridged', interactive: false}).addTo(g);
    });
    layers['bridged frames'] = g.addTo(map);
  }
  if (d.map_fixes.length) {
    // One marker per fix against the reference map, coloured by what became of it, a tooltip
    // with its frame and error to GPS.
    var names = {fused: 'map fixes fused', recorded: 'map fixes (not fused)',
                 gated: 'map fixes rejected by a gate'};
    var groups = {};
    d.map_fixes.forEach(function (f) {
      var g = groups[f[2]] || (groups[f[2]] = L.layerGroup());
      var tip = 'map fix · frame ' + f[3] + ' · ' + f[4].toFixed(1) + ' s · ' + f[2] +
          (f[5] === null ? '' : ' · to GPS ' + f[5].toFixed(2) + ' m') +
          (f[6] === null ? '' : ' · map ' + f[6]);
      L.circleMarker([f[0], f[1]], {radius: 5, color: d.colours.map_fix[f[2]], weight: 2,
                                    fillOpacity: 0.6, className: 'aerovo-map-fix aerovo-map-fix-' + f[2]})
          .bindTooltip(tip).addTo(g);
    });
    Object.keys(groups).forEach(function (k) { layers[names[k]] = groups[k].addTo(map); });
  }
  L.control.layers(null, layers, {collapsed: false}).addTo(map);
  var all = d.vo.concat(d.gps, d.truth, d.vo_optimized);
  if (all.length) map.fitBounds(L.latLngBounds(all), {padding: [24, 24], animate: false});
  function metres(v) { return v === null ? null : v.toFixed(2) + ' m'; }
  function text(i) {
    var f = d.info[i], s = 'frame ' + f[0] + ' · ' + f[1].toFixed(1) + ' s · ' + f[2];
    if (f[3] === null) return s + ' · no GPS fix';
    s += ' · to GPS ' + metres(f[3]) + ' as drawn';
    if (f[4] !== null) s += ', ' + metres(f[4]) + ' after SE(2) alignment';
    return s;
  }
  function escape(t) {
    return t.replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;');
  }
  var cursor = L.circleMarker([0, 0], {radius: 7, color: '#000', weight: 2, fill: false,
                                       interactive: false});
  cursor.bindTooltip('', {direction: 'top', offset: [0, -8]});
  var projected = [], zoom = null;
  function show(i) {
    cursor.setLatLng(d.vo[i]);
    if (!map.hasLayer(cursor)) cursor.addTo(map);
    cursor.setTooltipContent(escape(text(i)));
    cursor.openTooltip();
  }
  function hide() { if (map.hasLayer(cursor)) map.removeLayer(cursor); }
  map.on('mousemove', function (e) {
    if (zoom !== map.getZoom()) {
      zoom = map.getZoom();
      projected = d.vo.map(function (p) { return map.project(p, zoom); });
    }
    var q = map.project(e.latlng, zoom), best = -1, best_d2 = 14 * 14;
    for (var i = 0; i < projected.length; i++) {
      var dx = projected[i].x - q.x, dy = projected[i].y - q.y, d2 = dx * dx + dy * dy;
      if (d2 < best_d2) { best_d2 = d2; best = i; }
    }
    if (best >= 0) show(best); else hide();
  });
  map.on('mouseout', hide);
  window.aerovoMap = {map: map, data: d, text: text, show: show};
})();
)js";

// The map section: the tracks on the geo-referenced mosaic; a note instead when the run has no
// geographic position at all.
void MapSection(const fs::path& dir, const RunData& run, const RunComparison& cmp,
                const std::optional<RunComparison>& truth, Page& page, ReportResult& result) {
  page.H2("Map", "map");
  nlohmann::json data = MapData(run, cmp, truth);
  if (data["vo"].empty() && data["gps"].empty()) {
    // On the page only: the run's summary already says why there is no comparison.
    page.Note("No map: the run has neither a geo-referenced VO position nor a GPS fix.");
    return;
  }
  std::string note;
  data["mosaic"] = GeoMosaicOverlay(dir, &note);
  if (!note.empty()) AddNote(page, result, note);
  page.head += "<style>\n" + LeafletCssInline() + "\n</style>\n<script>\n" +
               leaflet::LicenceComment() + std::string(leaflet::Js()) + "\n</script>\n";
  HtmlBuilder& b = page.body;
  const auto key = [&b](style::Rgb colour, const std::string& text) {
    b.Open("span", {{"style", "background:" + style::Hex(colour)}}).Close("span").Text(text);
  };
  b.Open("p", {{"class", "map-legend"}});
  key(style::kVo, fmt::format("VO ({} geo-referenced frames)", data["vo"].size()));
  key(style::kGps, fmt::format("GPS ({} fixes)", data["gps"].size()));
  if (!data["truth"].empty()) key(style::kTruth, "ground truth");
  if (!data["vo_optimized"].empty()) {
    key(style::kVoOptimized, "VO optimised after the flight (vo_optimized.*)");
  }
  if (!data["bridged"].empty()) key(style::kBridged, "bridged frames");
  int kinds[3] = {0, 0, 0};  // fused, recorded, gated
  for (const auto& f : data["map_fixes"]) {
    const std::string k = f[2];
    ++kinds[k == "fused" ? 0 : k == "recorded" ? 1 : 2];
  }
  if (kinds[0] > 0) key(style::kMapFixFused, fmt::format("map fixes fused ({})", kinds[0]));
  if (kinds[1] > 0) key(style::kMapFixRecorded, fmt::format("map fixes, not fused ({})", kinds[1]));
  if (kinds[2] > 0) key(style::kMapFixGated, fmt::format("map fixes rejected by a gate ({})", kinds[2]));
  b.Close("p").Newline();
  page.body.Open("div", {{"id", "aerovo-map"}}).Close("div").Newline();
  page.Para(std::string("Drag to pan, scroll to zoom; hover over the VO track for a frame's index, "
                        "status and distance to its GPS fix. The tracks are drawn as the run wrote "
                        "them (VO geo-referenced at the first fix, no alignment); tick \"VO, "
                        "SE(2)-aligned to GPS\" for the track under the comparison's alignment. ") +
            (data["mosaic"].is_null() ? "No geo-referenced mosaic in this folder (mosaic_geo.json)."
                                      : "Under them, the geo-referenced north-up mosaic."));
  // JSON inside <script>: "</" written as "<\/" so that no string ends the element.
  std::string json = data.dump();
  for (std::size_t pos = json.find("</"); pos != std::string::npos;
       pos = json.find("</", pos + 3)) {
    json.replace(pos, 2, "<\\/");
  }
  page.body.Open("script", {{"type", "application/json"}, {"id", "aerovo-map-data"}});
  page.body.Raw(json).Close("script").Newline();
  page.body.Open("script").Raw(kMapScript).Close("script").Newline();
}

// The run folder `dir` read for its report: throws InputError when it has no frame rows.
RunData ReadRunForReport(const fs::path& dir) {
  RunData run = ReadRunDir(dir);
  if (run.frames.empty()) {
    throw InputError("'" + (dir / RunFileNames::kFramesCsv).string() + "' has no frame rows");
  }
  return run;
}

// Fills the page for the run folder `dir` read into `run` (ReadRunForReport); `cmp` is its
// comparison with its own GPS (CompareWithGps).
void RunReport(const fs::path& dir, const RunData& run, const RunComparison& cmp,
               const ReportOptions& options, Page& page, ReportResult& result) {
  const nlohmann::json summary = EffectiveSummary(run, cmp);
  page.title = "aerovo run report — " + DirName(dir);
  page.body.Open("p", {{"class", "meta"}})
      .Text("Run folder ")
      .Element("code", {}, fs::absolute(dir).string())
      .Text("; input ")
      .Element("code", {}, JsonString(summary, "input"))
      .Text(".")
      .Close("p")
      .Newline();
  page.body.Raw(
      "<nav><a href=\"#answer\">Answer</a><a href=\"#map\">Map</a>"
      "<a href=\"#comparison\">Accuracy</a><a href=\"#figures\">Figures</a>"
      "<a href=\"#summary\">Summary</a><a href=\"#timings\">Timings</a>"
      "<a href=\"#mosaic\">Mosaic</a><a href=\"#config\">Configuration</a></nav>\n");
  // The accuracy first, then the map, the comparison and figures; details and timings after.
  AnswerBox(page, summary);
  if (summary.contains("warnings") && summary["warnings"].is_array()) {
    for (const auto& w : summary["warnings"]) {
      if (w.is_string()) page.Note("warning: " + w.get<std::string>());
    }
  }
  std::optional<RunComparison> truth;
  if (const std::string file = JsonString(run.summary, "truth"); !file.empty()) {
    try {
      truth = CompareWithTruthFile(run, file);
    } catch (const InputError& e) {
      AddNote(page, result, std::string("no figure against the ground truth: ") + e.what());
    }
  }
  // The map is filled in last (below), so that it shows a geo-referenced mosaic written by
  // this report too; its place is here.
  const std::size_t map_at = page.body.size();
  ComparisonTables(page, summary);

  page.H2("Figures", "figures");
  FigureSink sink(dir, options, page, result);
  RunFigures(run, cmp, truth, sink);
  DetailsTables(page, summary);

  page.H2("Mosaic", "mosaic");
  if (!options.mosaic) {
    page.Note("Mosaic not drawn (--no-mosaic).");
  } else {
    const FramePixels pixels = FitFramePixels(run);  // once for all the tracks
    // GPS first (wider, underneath), the VO track on top: both stay visible where they agree.
    std::vector<MosaicTrack> tracks;
    MosaicTrack gps;
    gps.name = cmp.reference_name + " (through the SE(2) alignment)";
    gps.points_px = GpsInFirstFramePixels(pixels, cmp);
    gps.color_rgb = cmp.reference_name == "GPS" ? style::kGps : style::kTruth;
    gps.line_width_px = 4;
    if (!gps.points_px.empty()) tracks.push_back(gps);
    if (truth) {
      MosaicTrack t;
      t.name = "ground truth (through its SE(2) alignment)";
      t.points_px = GpsInFirstFramePixels(pixels, *truth);
      t.color_rgb = style::kTruth;
      t.line_width_px = 3;
      if (!t.points_px.empty()) tracks.push_back(t);
    }
    MosaicTrack vo;
    vo.name = run.transforms_optimized.empty() ? "VO (estimated transforms)" : "VO, causal";
    vo.points_px = pixels.centres_px;
    vo.color_rgb = style::kVo;
    vo.line_width_px = 2;
    tracks.push_back(vo);
    if (!run.transforms_optimized.empty()) {
      MosaicTrack opt;
      opt.name = "VO optimised after the flight";
      opt.points_px = FrameCentresPx(run, nullptr, &run.transforms_optimized);
      opt.color_rgb = style::kVoOptimized;
      opt.line_width_px = 2;
      tracks.push_back(opt);
    }
    const fs::path file = dir / ReportFileNames::kFiguresDir / ReportFileNames::kMosaic;
    Stopwatch sw;
    const MosaicResult m = BuildMosaic(run, tracks, file, options.mosaic_options);
    if (options.log) {
      *options.log << fmt::format("  mosaic: {} ({:.1f} s)\n", m.note, sw.elapsed_ms() / 1000.0);
    }
    if (m.written) {
      result.mosaic = m.file;
      result.figures.push_back(m.file);
      sink.AddImage(m.file, "mosaic",
                    std::string(m.optimized ? "Mosaic: frames placed by the offline "
                                              "optimisation's poses (transforms_optimized.csv)"
                                            : "Mosaic: frames warped by the estimated transforms") +
                        " into the first frame's pixels, with the VO track (orange" +
                        (m.optimized ? "; the optimised one purple" : "") + "), the " +
                        cmp.reference_name + " track (blue)" +
                        (truth ? std::string(" and the ground truth (green)") : std::string()) +
                        "; " + m.note + ".");
    } else {
      AddNote(page, result, m.note);
    }
    // The geo-referenced north-up mosaics (report/geo_mosaic.h): mosaic.tif, mosaic.kmz,
    // mosaic_geo.png/.json in DIR; a one-line note when the run is not geo-referenced.
    const GeoMosaicResult geo = WriteGeoMosaic(
        run, dir, FlightNameOf(JsonString(run.config, "input")), options.mosaic_options);
    if (options.log) *options.log << "  geo mosaic: " << geo.note << "\n";
    if (!geo.written && m.written) AddNote(page, result, geo.note);  // else: the mosaic's note
  }

  page.H2("Effective configuration (config.json)", "config");
  if (run.config.is_object()) {
    std::vector<std::vector<std::string>> rows;
    FlattenJson(run.config, "", &rows);
    page.Table({"key", "value"}, rows, "kv");
  } else {
    page.Note("config.json is missing.");
  }

  Page map;
  MapSection(dir, run, cmp, truth, map, result);
  page.body.Insert(map_at, map.body);
  page.head += map.head;
}

// The footer, then DIR/report.html; the time since `sw` started.
void FinishReport(const fs::path& dir, const Stopwatch& sw, Page& page, ReportResult& result) {
  page.body.Raw(
      "<p class=\"meta\">Generated by <code>aerovo report</code>; figures drawn with "
      "gnuplot, also in <code>figures/</code> as SVG and PNG.</p>\n");
  result.html = dir / ReportFileNames::kHtml;
  WriteTextFileAtomic(result.html, page.Html());
  result.seconds = sw.elapsed_ms() / 1000.0;
}

// WriteReport for the run folder `dir` already read into `run` (RunReport's preconditions), so
// that the experiment report renders its runs' reports from what it read.
ReportResult WriteRunReport(const fs::path& dir, const RunData& run, const RunComparison& cmp,
                            const ReportOptions& options, const Stopwatch& sw) {
  ReportResult result;
  result.kind = "run";
  Page page;
  RunReport(dir, run, cmp, options, page, result);
  FinishReport(dir, sw, page, result);
  return result;
}

// ---------------------------------------------------------------------------------------------
// Experiment folder

struct ExpRun {
  std::string label, dir;
  nlohmann::json spec;
  RunData data;
  RunComparison cmp;
};

// EXP/experiment.json, an object with a "runs" array.
nlohmann::json ReadExperimentJson(const fs::path& json_path) {
  nlohmann::json exp;
  try {
    exp = nlohmann::json::parse(ReadFile(json_path));
  } catch (const nlohmann::json::exception& e) {
    throw InputError("'" + json_path.string() + "': " + e.what());
  }
  if (!exp.is_object() || !exp.contains("runs") || !exp["runs"].is_array()) {
    throw InputError("'" + json_path.string() + "': expected an object with a \"runs\" array");
  }
  return exp;
}

// The simulated flight's ground truth of experiment.json; no points when none or unreadable
// (then a note says why).
ReferenceTrack ReadExperimentGroundTruth(const fs::path& dir, const nlohmann::json& exp, Page& page,
                                         ReportResult& result) {
  ReferenceTrack ground_truth;  // no points: none
  if (exp.contains("ground_truth") && exp["ground_truth"].is_string()) {
    fs::path gt = exp["ground_truth"].get<std::string>();
    if (gt.is_relative()) gt = dir / gt;
    try {
      ground_truth = ReadGroundTruthCsv(gt);
    } catch (const InputError& e) {
      const std::string note = std::string("ground truth not used: ") + e.what();
      AddNote(page, result, note);
    }
  }
  return ground_truth;
}

// The run's own report (options.sub_reports): a failure is a note.
void WriteExperimentSubReport(const ExpRun& run, const fs::path& run_dir,
                              const ReferenceTrack& ground_truth, const ReportOptions& options,
                              Page& page, ReportResult& result) {
  ReportOptions sub = options;
  sub.log = nullptr;
  try {
    const Stopwatch sub_sw;
    // From the rows read above; the run's own report compares it with its own GPS. A run
    // folder holding an experiment.json is an experiment for WriteReport.
    const ReportResult s =
        fs::is_regular_file(run_dir / ReportFileNames::kExperimentJson)
            ? WriteReport(run_dir, sub)
            : WriteRunReport(run_dir, run.data,
                             ground_truth.points.empty() ? run.cmp : CompareWithGps(run.data), sub,
                             sub_sw);
    result.sub_reports.push_back(s.html);
  } catch (const std::exception& e) {
    const std::string note = "run '" + run.label + "': its own report failed: " + e.what();
    AddNote(page, result, note);
  }
}

// The runs of experiment.json that have results, read and compared with the reference; the
// others are notes. Throws InputError when none has.
std::vector<ExpRun> ReadExperimentRuns(const fs::path& dir, const fs::path& json_path,
                                       const nlohmann::json& exp,
                                       const ReferenceTrack& ground_truth,
                                       const ReportOptions& options, Page& page,
                                       ReportResult& result) {
  std::vector<ExpRun> runs;
  for (std::size_t i = 0; i < exp["runs"].size(); ++i) {
    const nlohmann::json& r = exp["runs"][i];
    ExpRun run;
    run.spec = r;
    run.dir = JsonString(r, "dir");
    run.label = JsonString(r, "label");
    if (run.dir.empty()) {
      throw InputError("'" + json_path.string() + "': runs[" + std::to_string(i) +
                       "] has no \"dir\"");
    }
    if (run.label.empty()) run.label = run.dir;
    const fs::path run_dir = dir / run.dir;
    if (!IsRunDir(run_dir)) {
      const std::string note = "run '" + run.label + "': no frames.csv in '" + run_dir.string() +
                               "' (not run, or failed): left out";
      AddNote(page, result, note);
      continue;
    }
    run.data = ReadRunDir(run_dir);
    if (run.data.frames.empty()) {
      const std::string note = "run '" + run.label + "': no frames: left out";
      AddNote(page, result, note);
      continue;
    }
    run.cmp = ground_truth.points.empty() ? CompareWithGps(run.data)
                                          : CompareWithReference(run.data, ground_truth);
    if (options.sub_reports) {
      WriteExperimentSubReport(run, run_dir, ground_truth, options, page, result);
    }
    runs.push_back(std::move(run));
  }
  if (runs.empty()) throw InputError("'" + json_path.string() + "': none of the runs has results");
  return runs;
}

// "Runs": one row per run, and the links to each run's own report.
void ExperimentRunsSection(const std::vector<ExpRun>& runs, const std::string& ref_name,
                           Page& page) {
  page.H2("Runs", "runs");
  std::vector<std::vector<std::string>> rows;
  for (const ExpRun& r : runs) {
    const RunData& d = r.data;
    double nsurf = 0, corr = 0, total = 0;
    int bridged = 0;
    for (const RunFrameRow& f : d.frames) {
      nsurf += f.n_surf;
      corr += f.correspond_ms;
      total += f.total_ms;
      if (f.status.rfind("bridged", 0) == 0) ++bridged;
    }
    const double n = static_cast<double>(d.frames.size());
    const auto& c = r.cmp.comparison;
    rows.push_back({r.label, fmt::format("{}", d.frames.size()), fmt::format("{}", bridged),
                    Num(nsurf / n, 0), c ? Num(c->se2.ate_m.rmse, 2) : "–",
                    c ? Num(c->sim2.ate_m.rmse, 2) : "–",
                    c ? Num(c->se2.end_point_error_percent, 2) : "–", Num(corr / n, 2),
                    Num(total / n, 1), Num(JsonNumber(d.summary, {"fps"}), 2)});
  }
  page.Table(
      {"run", "frames", "bridged", "mean N_SURF", "ATE RMSE SE(2) (m)", "ATE RMSE Sim(2) (m)",
       "end-point error SE(2) (%)", "mean correspond (ms)", "mean total (ms)", "fps"},
      rows);
  page.Para(HtmlBuilder().Text("Errors against ").Text(ref_name).Raw(". Each run's own report:"));
  page.body.Open("ul").Newline();
  for (const ExpRun& r : runs) {
    const std::string href = r.dir + "/" + ReportFileNames::kHtml;
    page.body.Open("li").Element("a", {{"href", href}}, r.label).Close("li").Newline();
  }
  page.body.Close("ul").Newline();
}

// One "Table: name" section per table of experiment.json, in its order.
void ExperimentTablesSection(const nlohmann::json& exp, Page& page) {
  if (!exp.contains("tables") || !exp["tables"].is_object()) return;
  for (auto it = exp["tables"].begin(); it != exp["tables"].end(); ++it) {
    const nlohmann::json& t = *it;
    std::vector<std::string> header;
    std::vector<std::vector<std::string>> rows;
    if (t.contains("columns") && t["columns"].is_array()) {
      for (const auto& c : t["columns"]) header.push_back(JsonCell(c));
    }
    if (t.contains("rows") && t["rows"].is_array()) {
      for (const auto& r : t["rows"]) {
        std::vector<std::string> row;
        if (r.is_array()) {
          for (const auto& c : r) row.push_back(JsonCell(c));
        }
        rows.push_back(row);
      }
    }
    page.H2("Table: " + it.key());
    page.Table(header, rows);
  }
}

// What an experiment's figures are drawn from.
struct ExperimentFigureInput {
  const std::vector<ExpRun>& runs;
  const ReferenceTrack& ground_truth;  ///< No points: the reference is each run's GPS.
  const std::string& ref_name;         ///< "ground truth" or "GPS".
  FigureSink& sink;
  Page& page;
};

// The trajectories of every run against the reference, in one figure.
void TrajectoriesFigure(const ExperimentFigureInput& in, const std::string& name,
                        const std::string& title, const std::string& caption) {
  Figure f = MapFigure(name);
  f.title = title;
  bool reference_drawn = false;
  std::string skipped;
  for (const ExpRun& r : in.runs) {
    if (!r.cmp.comparison) {
      skipped += (skipped.empty() ? "" : ", ") + r.label;
      continue;
    }
    if (!reference_drawn) {
      std::vector<double> gx, gy;
      if (!in.ground_truth.points.empty()) {
        for (const ReferencePoint& p : in.ground_truth.points) {
          gx.push_back(p.x_m);
          gy.push_back(p.y_m);
        }
      } else {
        for (const TrajectoryPoint2D& p : r.cmp.reference) {
          gx.push_back(p.x);
          gy.push_back(p.y);
        }
      }
      f.series.push_back(
          Series(in.ref_name, gx, gy, SeriesStyle::kLines,
                 style::Hex(in.ground_truth.points.empty() ? style::kGps : style::kTruth)));
      f.series.back().line_width = 3.0;
      reference_drawn = true;
    }
    std::vector<double> x, y;
    AlignedTrack(r.data, r.cmp.comparison->se2.alignment.enu_from_vo, &x, &y);
    f.series.push_back(
        Series(fmt::format("{} (ATE {:.2f} m)", r.label, r.cmp.comparison->se2.ate_m.rmse), x, y));
  }
  if (f.series.empty()) {
    in.page.Note("No trajectory figure: no run could be compared with " + in.ref_name + ".");
    return;
  }
  FitMapHeight(f);
  in.sink.Add(f, caption);
  if (!skipped.empty()) {
    in.sink.Note("Not in the trajectory figure (fewer than 3 frames could be aligned with " +
                 in.ref_name + ", e.g. every step bridged): " + skipped + ".");
  }
}

// N_SURF per frame, one curve per run.
Figure NsurfPerFrameFigure(const std::vector<ExpRun>& runs, const std::string& name,
                           const std::string& title) {
  Figure f;
  f.name = name;
  f.title = title;
  f.x_label = "frame";
  f.y_label = "N_SURF (interest points per frame)";
  f.key = "outside right top";
  for (const ExpRun& r : runs) {
    f.series.push_back(Series(r.label, FrameAxis(r.data),
                              Column(r.data, [](const RunFrameRow& q) { return q.n_surf; })));
  }
  return f;
}

// Illumination (paper Figs. 4-6): N_SURF per frame, mean N_SURF against k, the trajectories.
void IlluminationFigures(const ExperimentFigureInput& in) {
  Figure f4 = NsurfPerFrameFigure(in.runs, "fig4_nsurf_per_frame",
                                  "Fig. 4: N_SURF per frame, one curve per illumination f_k = k f");
  f4.y_from_zero = true;
  std::vector<std::pair<double, double>> k_mean;  // (k, mean N_SURF)
  for (const ExpRun& r : in.runs) {
    if (r.spec.contains("k") && r.spec["k"].is_number()) {
      double sum = 0;
      for (const RunFrameRow& q : r.data.frames) sum += q.n_surf;
      k_mean.emplace_back(r.spec["k"].get<double>(), sum / r.data.frames.size());
    }
  }
  in.sink.Add(f4,
              "Figs. 4 and 5 of the paper: the number of interest points on each frame, one "
              "curve per illumination factor k.");
  if (!k_mean.empty()) {
    std::stable_sort(k_mean.begin(), k_mean.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<double> sk, sm;
    for (const auto& [k, mean] : k_mean) {
      sk.push_back(k);
      sm.push_back(mean);
    }
    Figure f5;
    f5.name = "fig5_mean_nsurf_vs_k";
    f5.title = "Fig. 5: mean N_SURF per frame against the illumination factor k";
    f5.x_label = "illumination factor k (pixel brightness x k)";
    f5.y_label = "mean N_SURF per frame";
    f5.key = "top left";
    f5.series.push_back(Series("mean N_SURF", sk, sm, SeriesStyle::kLinesPoints));
    f5.series.back().point_size = 1.2;
    in.sink.Add(f5, "Mean number of interest points per frame against k (summary of Figs. 4, 5).");
  }
  TrajectoriesFigure(in, "fig6_trajectories",
                     "Fig. 6: trajectories at different illumination k against " + in.ref_name,
                     "Fig. 6 of the paper: trajectories computed at each k with the same "
                     "parameters, each SE(2)-aligned to " +
                         in.ref_name + ".");
}

// RANSAC (paper Figs. 7-8): the stage times per step of each mode, the correspondence stage of
// both side by side, the trajectories.
void RansacFigures(const ExperimentFigureInput& in) {
  Figure f8;
  f8.name = "fig8_correspond_per_step";
  f8.title = "Correspondence stage time per step, by RANSAC mode";
  f8.x_label = "frame";
  f8.y_label = "correspond time (ms)";
  f8.log_y = true;
  for (const ExpRun& r : in.runs) {
    const std::string mode = JsonString(r.spec, "mode");
    const bool clustered = mode == "clustered" || r.dir == "clustered";
    std::string name = std::string(clustered ? "fig8" : "fig7") + "_stage_times_" + r.dir;
    for (char& ch : name) {
      if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-')) ch = '_';
    }
    const Figure f = StageTimesFigure(
        r.data, name,
        fmt::format("Fig. {}: time of each stage per step, {} RANSAC", clustered ? 8 : 7, r.label));
    in.sink.Add(f, fmt::format("Fig. {} of the paper: time of each stage per step with {} "
                               "RANSAC, milliseconds (log scale).",
                               clustered ? 8 : 7, r.label));
    const PlotSeries& correspond = f.series[kStageTimesCorrespond];
    f8.series.push_back(Series(r.label, correspond.x, correspond.y));
  }
  in.sink.Add(f8,
              "The correspondence stage (matching + RANSAC) of each mode side by side, "
              "milliseconds (log scale).");
  TrajectoriesFigure(in, "trajectories", "Trajectories of each RANSAC mode against " + in.ref_name,
                     "Each mode's trajectory, SE(2)-aligned to " + in.ref_name + ".");
}

// An experiment of a kind this version does not know: N_SURF per frame and the trajectories.
void GenericExperimentFigures(const ExperimentFigureInput& in) {
  in.sink.Add(NsurfPerFrameFigure(in.runs, "nsurf_per_frame", "N_SURF per frame, each run"),
              "Interest points per frame of each run.");
  TrajectoriesFigure(in, "trajectories", "Trajectories of each run against " + in.ref_name,
                     "Each run's trajectory, SE(2)-aligned to " + in.ref_name + ".");
}

// The figures of each experiment kind (report/experiment_kind.h), in enum order.
struct ExperimentFigures {
  ExperimentKind kind;
  void (*add)(const ExperimentFigureInput& in);
};
constexpr ExperimentFigures kExperimentFigures[] = {
    {ExperimentKind::kIllumination, IlluminationFigures},
    {ExperimentKind::kRansac, RansacFigures},
};

constexpr bool EveryExperimentKindHasFigures() {
  if (std::size(kExperimentFigures) != kNumExperimentKinds) return false;
  for (std::size_t i = 0; i < kNumExperimentKinds; ++i) {
    if (kExperimentFigures[i].kind != kAllExperimentKinds[i]) return false;
  }
  return true;
}
static_assert(EveryExperimentKindHasFigures(),
              "kExperimentFigures: one entry per ExperimentKind, in enum order");

// The figures of experiment `kind` (experiment.json's "kind"); the generic ones for a kind
// this version does not know.
void AddExperimentFigures(const std::string& kind, const ExperimentFigureInput& in) {
  if (const std::optional<ExperimentKind> k = ParseExperimentKind(kind)) {
    for (const ExperimentFigures& e : kExperimentFigures) {
      if (e.kind == *k) return e.add(in);
    }
  }
  GenericExperimentFigures(in);
}

void ExperimentReport(const fs::path& dir, const ReportOptions& options, Page& page,
                      ReportResult& result) {
  const fs::path json_path = dir / ReportFileNames::kExperimentJson;
  const nlohmann::json exp = ReadExperimentJson(json_path);
  const std::string kind = JsonString(exp, "kind");
  page.title = "aerovo experiment report — " + (kind.empty() ? std::string("experiment") : kind) +
               " (" + DirName(dir) + ")";
  page.body.Open("p", {{"class", "meta"}})
      .Text("Experiment folder ")
      .Element("code", {}, fs::absolute(dir).string())
      .Text(".")
      .Close("p")
      .Newline();

  // Reference: the simulated flight's ground truth, else each run's GPS.
  const ReferenceTrack ground_truth = ReadExperimentGroundTruth(dir, exp, page, result);
  const std::vector<ExpRun> runs =
      ReadExperimentRuns(dir, json_path, exp, ground_truth, options, page, result);
  const std::string ref_name = ground_truth.points.empty() ? "GPS" : "ground truth";

  ExperimentRunsSection(runs, ref_name, page);
  ExperimentTablesSection(exp, page);
  page.H2("Figures", "figures");
  FigureSink sink(dir, options, page, result);
  AddExperimentFigures(kind, {runs, ground_truth, ref_name, sink, page});
}

}  // namespace

ReportResult WriteReport(const fs::path& dir, const ReportOptions& options) {
  Validate(options.mosaic_options);
  Stopwatch sw;
  if (fs::is_regular_file(dir / ReportFileNames::kExperimentJson)) {
    ReportResult result;
    Page page;
    result.kind = "experiment";
    if (options.log) *options.log << "aerovo report: experiment folder " << dir.string() << "\n";
    ExperimentReport(dir, options, page, result);
    FinishReport(dir, sw, page, result);
    return result;
  }
  if (IsRunDir(dir)) {
    if (options.log) *options.log << "aerovo report: run folder " << dir.string() << "\n";
    const RunData run = ReadRunForReport(dir);
    // summary.json and config.json are read as aerovo run writes them: a value of another JSON
    // type (a damaged or hand-edited file: "interrupted": "yes", null) made nlohmann's accessors
    // throw, and the error named neither the file nor the folder.
    try {
      return WriteRunReport(dir, run, CompareWithGps(run), options, sw);
    } catch (const nlohmann::json::exception& e) {
      throw InputError("'" + (dir / RunFileNames::kSummaryJson).string() + "' or '" +
                       (dir / RunFileNames::kConfigJson).string() +
                       "' holds a value of another type than aerovo run writes (" + e.what() +
                       "): a damaged or edited file; remove summary.json to have the report "
                       "recompute its figures from frames.csv");
    }
  }
  throw InputError("'" + dir.string() + "' is neither a run folder (no " +
                   RunFileNames::kFramesCsv + ") nor an experiment folder (no " +
                   ReportFileNames::kExperimentJson + ")");
}

}  // namespace aerovo
