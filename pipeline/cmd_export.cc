// `shadowsg export --lighting FILE --out PATH --format F`: the lighting as an
// env-map EXR (ours or OpenEXR/USD's layout), a USD dome light, a Blender
// world script or SG JSON (stages/export_stage.h).
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/export_stage.h"

namespace shadowsg {

void RegisterExportCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string lighting, out;
    ExportOptions exp;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("export", "Write a lighting estimate for other tools (EXR, USD, Blender, JSON)");
  cmd->add_option("--lighting", opt->lighting, "lighting.json (SG), an env-map .exr or a lights/1 JSON")->required();
  cmd->add_option("--out", opt->out, "Output file: .exr (exr, openexr), .usda (usd), .py (blender), .json (json)")
      ->required();
  cmd->add_option("--format", opt->exp.format,
                  "exr (shadowsg layout), openexr (OpenEXR/USD lat-long, y-up), usd (DomeLight .usda + .exr), "
                  "blender (world script .py + .exr), json (SG lobes)")
      ->check(CLI::IsMember({"exr", "openexr", "usd", "blender", "json"}))
      ->capture_default_str();
  cmd->add_option("--height", opt->exp.height, "Map height H (width 2H); 0: the lighting's own (256 for SG)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] { RunExport(opt->lighting, opt->out, opt->exp, MakeContext(opt->common)); });
}

}  // namespace shadowsg
