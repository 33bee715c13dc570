#include "stages/bench/html.h"

#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include "calib/error.h"
#include "stages/bench/tables.h"
#include "stages/colmap_runner.h"
#include "stages/io/atomic_file.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// Markdown inline (`code`, **bold**) of the shared notes, as HTML.
std::string Inline(const std::string& md) {
  std::string s = Escape(md), out;
  bool code = false, bold = false;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '`') {
      out += code ? "</code>" : "<code>";
      code = !code;
    } else if (!code && s.compare(i, 2, "**") == 0) {
      out += bold ? "</b>" : "<b>";
      bold = !bold;
      ++i;
    } else {
      out += s[i];
    }
  }
  if (code) out += "</code>";
  if (bold) out += "</b>";
  return out;
}

// A relative path as a URL: every byte outside the unreserved set and '/'
// percent-encoded ('+' too, which some servers read as a space).
std::string Url(const fs::path& rel) {
  std::string out;
  for (unsigned char c : rel.generic_string()) {
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~' || c == '/') {
      out += static_cast<char>(c);
    } else {
      char buf[4];
      std::snprintf(buf, sizeof buf, "%%%02X", c);
      out += buf;
    }
  }
  return out;
}

std::string Decode(const std::string& url) {
  std::string out;
  for (size_t i = 0; i < url.size(); ++i) {
    if (url[i] == '%' && i + 2 < url.size() && std::isxdigit(static_cast<unsigned char>(url[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(url[i + 2]))) {
      out += static_cast<char>(std::stoi(url.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += url[i];
    }
  }
  return out;
}

std::string Table(const TextTable& t) {
  std::ostringstream h;
  h << "<table>\n<tr>";
  for (size_t c = 0; c < t.header.size(); ++c) h << "<th>" << Escape(t.header[c]) << "</th>";
  h << "</tr>\n";
  for (size_t i = 0; i < t.rows.size(); ++i) {
    h << "<tr>";
    for (size_t c = 0; c < t.rows[i].size(); ++c) {
      const bool num = c < t.numeric.size() && t.numeric[c];
      const bool b = i < t.bold.size() && c < t.bold[i].size() && t.bold[i][c];
      h << "<td" << (num ? " class=\"n\"" : "") << ">" << (b ? "<b>" : "") << Escape(t.rows[i][c])
        << (b ? "</b>" : "") << "</td>";
    }
    h << "</tr>\n";
  }
  h << "</table>\n";
  for (const std::string& n : t.notes) h << "<p class=\"note\">" << Inline(n) << "</p>\n";
  return h.str();
}

// <img> of a file under DIR when it exists, else a grey placeholder cell.
std::string Img(const fs::path& bench_dir, const fs::path& rel, const std::string& alt) {
  std::error_code ec;
  if (!fs::is_regular_file(bench_dir / rel, ec)) return "<div class=\"missing\">" + Escape(alt) + ": none</div>";
  return "<a href=\"" + Url(rel) + "\"><img src=\"" + Url(rel) + "\" alt=\"" + Escape(alt) + "\"></a>";
}

constexpr const char* kStyle = R"(
body { font-family: sans-serif; margin: 1.5em; color: #222; max-width: 1400px; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; }
th { background: #f0f0f0; }
td.n { text-align: right; font-variant-numeric: tabular-nums; }
p.note { font-size: 0.85em; color: #555; margin: 0.2em 0; }
figure { display: inline-block; margin: 0.5em; vertical-align: top; max-width: 640px; }
figure img { width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.85em; color: #555; }
table.strip img { height: 150px; display: block; }
table.strip td { vertical-align: top; text-align: center; font-size: 0.8em; }
div.missing { height: 150px; width: 150px; background: #eee; color: #888; font-size: 0.8em; }
code { background: #f4f4f4; padding: 0 0.2em; }
)";

// The page's load handler records how many images have no pixels; the
// Chromium check reads it back from the DOM.
constexpr const char* kImageCheck = R"(<script>
window.addEventListener('load', () => {
  const bad = [...document.images].filter(i => !i.complete || i.naturalWidth === 0).map(i => i.getAttribute('src'));
  document.body.dataset.brokenImages = bad.length;
  document.body.dataset.brokenList = bad.join(' ');
});
</script>
)";

}  // namespace

void WriteIndexHtml(const BenchReport& r, const std::vector<BenchChart>& charts, const fs::path& bench_dir) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>shadowsg bench</title>\n<style>"
    << kStyle << "</style>\n</head>\n<body>\n<h1>shadowsg bench</h1>\n";
  for (const std::string& n : ReportNotes(r)) h << "<p>" << Inline(n) << "</p>\n";
  h << "<p>Files: ";
  bool first = true;
  for (const char* f : {"results.md", "results.csv", "stability.csv"}) {
    std::error_code ec;
    if (!fs::is_regular_file(bench_dir / f, ec)) continue;
    h << (first ? "" : ", ") << "<a href=\"" << f << "\">" << f << "</a>";
    first = false;
  }
  h << ".</p>\n<ul>\n";
  if (OverviewTable(r)) h << "<li><a href=\"#overview\">Overview</a></li>\n";
  if (!charts.empty()) h << "<li><a href=\"#charts\">Charts</a></li>\n";
  for (size_t i = 0; i < r.scenes.size(); ++i)
    h << "<li><a href=\"#scene" << i << "\">" << Escape(r.scenes[i].name) << "</a></li>\n";
  if (r.stability) h << "<li><a href=\"#stability\">Stability</a></li>\n";
  h << "</ul>\n";

  if (const auto overview = OverviewTable(r))
    h << "<h2 id=\"overview\">Overview: PSNR (dB) per scene</h2>\n" << Table(*overview);
  if (!charts.empty()) {
    h << "<h2 id=\"charts\">Charts</h2>\n";
    for (const BenchChart& c : charts)
      h << "<figure><a href=\"" << Url(c.svg) << "\"><img src=\"" << Url(c.png) << "\" alt=\"" << Escape(c.title)
        << "\"></a><figcaption>" << Escape(c.title) << ". " << Escape(c.caption) << " (<a href=\"" << Url(c.svg)
        << "\">SVG</a>, <a href=\"" << Url(fs::path("charts") / (c.name + ".gp")) << "\">gnuplot script</a>)"
        << "</figcaption></figure>\n";
  }

  for (size_t i = 0; i < r.scenes.size(); ++i) {
    const BenchScene& scene = r.scenes[i];
    h << "<h2 id=\"scene" << i << "\">" << Escape(scene.name) << "</h2>\n<p>" << Inline(SceneLine(scene)) << "</p>\n"
      << Table(SceneTable(r, scene));
    const fs::path scene_runs = fs::path("runs") / scene.name;
    h << "<h3>Images</h3>\n<p class=\"note\">Re-renders and the input share one exposure (the brightest plane "
         "pixel of the input is white); error maps: |render - input| on the plane, full scale = 10 % of that "
         "maximum; env maps: each tone-mapped to its own 99th percentile.</p>\n<table class=\"strip\">\n"
      << "<tr><th>Setting</th><th>Re-render</th><th>Error</th><th>Env map</th></tr>\n"
      << "<tr><td>input / truth</td><td>" << Img(bench_dir, scene_runs / "input.png", "input") << "input</td><td></td><td>"
      << Img(bench_dir, scene_runs / "env_gt.png", "true env map") << "true env map</td></tr>\n";
    for (const BenchRun* run : RunsInTableOrder(r, scene)) {
      const std::string name = MethodDisplayName(run->setting.method) + " " + run->setting.label;
      char caption[96] = "failed";
      if (run->ok())
        std::snprintf(caption, sizeof caption, "%.2f dB", run->Number("psnr").value_or(0));
      h << "<tr><td>" << Escape(name) << "<br>" << caption << "</td><td>"
        << Img(bench_dir, run->run_dir / "render.png", name + " re-render") << "</td><td>"
        << Img(bench_dir, run->run_dir / "error.png", name + " error") << "</td><td>"
        << Img(bench_dir, run->run_dir / "envmap.png", name + " env map") << "</td></tr>\n";
    }
    h << "</table>\n";
  }

  if (r.stability) {
    h << "<h2 id=\"stability\">Stability</h2>\n";
    for (const std::string& n : StabilityNotes(r)) h << "<p>" << Inline(n) << "</p>\n";
    h << Table(StabilityTable(r));
  }
  h << kImageCheck << "</body>\n</html>\n";
  WriteTextAtomically(bench_dir / "index.html", h.str());
}

std::vector<std::string> MissingLinks(const fs::path& html) {
  std::ifstream in(html);
  if (!in) throw InputError(html.string(), "cannot read");
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  static const std::regex kLink(R"re((?:src|href)\s*=\s*"([^"]*)")re", std::regex::icase);
  static const std::regex kScheme(R"(^[A-Za-z][A-Za-z0-9+.-]*:)");
  std::vector<std::string> missing;
  for (auto it = std::sregex_iterator(s.begin(), s.end(), kLink); it != std::sregex_iterator(); ++it) {
    std::string target = (*it)[1].str();
    if (target.empty() || target[0] == '#' || std::regex_search(target, kScheme)) continue;
    target = target.substr(0, target.find_first_of("?#"));
    std::error_code ec;
    if (!fs::exists(html.parent_path() / Decode(target), ec)) missing.push_back(target);
  }
  return missing;
}

void CheckHtmlInChromium(const fs::path& html, const fs::path& screenshot, const StageContext& ctx) {
  std::optional<fs::path> exe = FindExecutable("chromium");
  if (!exe) exe = FindExecutable("chromium-browser");
  if (!exe)
    throw InputError("chromium", "not found on PATH: --check-html loads index.html in headless Chromium (Debian: "
                                 "apt-get install chromium)");
  const std::string url = "file://" + Url(fs::absolute(html));
  const std::vector<std::string> common = {exe->string(), "--headless", "--no-sandbox", "--disable-gpu",
                                           "--hide-scrollbars", "--virtual-time-budget=15000"};
  static const std::regex kBroken(R"re(data-broken-images="(\d+)"(?:\s+data-broken-list="([^"]*)")?)re");
  std::string count, list, last;
  std::vector<std::string> argv = common;
  argv.push_back("--dump-dom");
  argv.push_back(url);
  const int status = RunProcess(argv, {}, [&](const std::string& line) {
    std::smatch m;
    if (std::regex_search(line, m, kBroken)) {
      count = m[1].str();
      list = m[2].str();
    } else if (!line.empty() && line.find("ERROR:") == std::string::npos) {
      last = line;
    }
  });
  if (status != 0)
    throw InputError(html.string(), "chromium failed (exit status " + std::to_string(status) + ")" +
                                        (last.empty() ? "" : ": " + last));
  if (count.empty()) throw InputError(html.string(), "chromium did not finish loading the page");
  if (count != "0") throw InputError(html.string(), count + " images did not load in chromium: " + list);
  argv = common;
  argv.push_back("--window-size=1400,3000");
  argv.push_back("--screenshot=" + fs::absolute(screenshot).string());
  argv.push_back(url);
  if (const int s = RunProcess(argv, {}, [](const std::string&) {}); s != 0 || !fs::exists(screenshot))
    throw InputError(screenshot.string(), "chromium wrote no screenshot (exit status " + std::to_string(s) + ")");
  ctx.Log("bench: index.html renders in headless chromium, every image loads; screenshot " + screenshot.string());
}

}  // namespace shadowsg
