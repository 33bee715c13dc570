// DIR/index.html of `shadowsg bench`: the tables, the charts and, per
// scene, an image strip (input, each setting's re-render, error map and
// estimated env map, the true env map). Every link is relative to DIR.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "stages/bench/bench_report.h"
#include "stages/bench/charts.h"
#include "stages/stage_context.h"

namespace shadowsg {

// Writes bench_dir/index.html. Links only files that exist.
void WriteIndexHtml(const BenchReport& report, const std::vector<BenchChart>& charts,
                    const std::filesystem::path& bench_dir);

// The relative src= and href= targets of an HTML file (percent-decoded) that
// do not exist, relative to its folder. Absolute URLs (scheme:) and
// fragments (#...) are not checked.
std::vector<std::string> MissingLinks(const std::filesystem::path& html);

// Loads the page in headless Chromium (Debian's `chromium`) and checks that
// it renders and that every image decoded (the page's load handler counts the
// images with no pixels). Writes a screenshot next to it. InputError with one
// line when Chromium is missing or the page fails.
void CheckHtmlInChromium(const std::filesystem::path& html, const std::filesystem::path& screenshot,
                         const StageContext& ctx);

}  // namespace shadowsg
