// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// rvwo-eval: judges an estimated trajectory against ground truth as evo does. Both files are in
// TUM format ("t x y z qx qy qz qw"). Poses are paired by nearest timestamp within a tolerance;
// the estimate is aligned to the ground truth (se3: Umeyama without scale; sim3: with scale;
// posyaw: rotation about z and translation; none); then
//   ATE: translation error of each pair after the alignment (evo_ape's default)
//   RPE: translation error of the relative motion over a delta of frames or metres (evo_rpe)
// It prints a report, and optionally writes it as JSON and a PNG of the trajectories seen from
// above (x, y) with the ATE over time. The equivalent evo commands are in docs/eval.md.
#include <cstdio>
#include <fstream>
#include <iomanip>

#include "support/command_line.h"
#include "support/plot.h"
#include "support/trajectory.h"

namespace {

using rvwo::apps::ErrorStats;

void printStats(const char* name, const ErrorStats& s, const char* unit) {
  std::printf("%s  rmse %.6f  mean %.6f  median %.6f  std %.6f  min %.6f  max %.6f %s  (%zu)\n", name, s.rmse, s.mean,
              s.median, s.std, s.min, s.max, unit, s.n);
}

void jsonStats(std::ostream& o, const ErrorStats& s) {
  o << "{\"rmse\": " << s.rmse << ", \"mean\": " << s.mean << ", \"median\": " << s.median << ", \"std\": " << s.std
    << ", \"min\": " << s.min << ", \"max\": " << s.max << ", \"n\": " << s.n << "}";
}

// The command line, in the order --help lists it.
struct EvalArgs {
  TCLAP::CmdLine cmd{
      "rvwo-eval: absolute trajectory error (ATE) and relative pose error (RPE) of an estimate against ground truth, "
      "both TUM files, computed as evo_ape / evo_rpe do (translation parts).",
      ' ', RVWO_VERSION};
  TCLAP::ValueArg<std::string> gt{"", "gt", "ground truth, TUM format", true, "", "GT.txt", cmd};
  TCLAP::ValueArg<std::string> est{"", "est", "the estimate, TUM format", true, "", "EST.txt", cmd};
  TCLAP::ValueArg<std::string> align{"", "align", "se3 (default), posyaw, sim3 or none", false, "se3", "mode", cmd};
  TCLAP::ValueArg<double> max_dt{"",  "max-dt", "largest timestamp difference of a pair, s (default 0.01)", false, 0.01,
                                 "s", cmd};
  TCLAP::ValueArg<double> delta{"", "delta", "RPE delta (default 1)", false, 1.0, "d", cmd};
  TCLAP::ValueArg<std::string> unit{"",    "delta-unit", "RPE delta in frames (f, default) or metres (m)", false, "f",
                                    "f|m", cmd};
  TCLAP::SwitchArg from_ref{"", "pairs-from-reference",
                            "RPE over metres: walk the ground truth's path, not the estimate's (as evo's flag)", cmd};
  TCLAP::ValueArg<std::string> json{"", "json", "also write the results as JSON", false, "", "R.json", cmd};
  TCLAP::ValueArg<std::string> plot{
      "", "plot", "also write a PNG: trajectories from above, ATE over time", false, "", "P.png", cmd};
  TCLAP::SwitchArg first_block{"", "first-block", "read only the first 'seq:' block of each file (OpenLORIS)", cmd};
};

void writeJson(const std::string& path, const rvwo::apps::AteResult& a, const rvwo::apps::RpeResult& r, EvalArgs& args,
               std::size_t pairs, double path_length) {
  std::ofstream o(path);
  if (!o) throw std::runtime_error("cannot write '" + path + "'");
  o << std::setprecision(12) << "{\"ate\": ";
  jsonStats(o, a.stats);
  o << ", \"rpe\": ";
  jsonStats(o, r.stats);
  o << ", \"rpe_delta\": " << args.delta.getValue() << ", \"rpe_delta_unit\": \"" << args.unit.getValue()
    << "\", \"pairs\": " << pairs << ", \"path_length\": " << path_length << ", \"align\": \"" << args.align.getValue()
    << "\", \"scale\": " << a.alignment.s << "}\n";
  if (!o) throw std::runtime_error("write to '" + path + "' failed");
}

// The trajectories from above (aligned) and the ATE over time.
void writePlot(const std::string& path, const rvwo::apps::AteResult& a, const std::string& align) {
  rvwo::apps::Plot xy("trajectories from above (" + align + " aligned)", "x [m]", "y [m]", true);
  std::vector<Eigen::Vector2d> g, s;
  for (std::size_t k = 0; k < a.ref.size(); ++k) {
    g.push_back(a.ref[k].head<2>());
    s.push_back(a.est_aligned[k].head<2>());
  }
  xy.add(g, mrpt::img::TColor(0, 0, 0), "ground truth", 2);
  xy.add(s, mrpt::img::TColor(0, 120, 220), "estimate", 2);
  rvwo::apps::Plot err("ATE over time: rmse " + std::to_string(a.stats.rmse) + " m", "t - t0 [s]", "error [m]");
  std::vector<Eigen::Vector2d> et;
  for (std::size_t k = 0; k < a.t.size(); ++k) et.emplace_back(a.t[k] - a.t.front(), a.errors[k]);
  err.add(et, mrpt::img::TColor(210, 60, 40), "ATE", 2);
  rvwo::apps::savePanels(path, {&xy, &err}, 1000, 560);
}

// Pairs, aligns, measures and reports.
int evaluate(EvalArgs& args) {
  if (args.unit.getValue() != "f" && args.unit.getValue() != "m") throw std::invalid_argument("--delta-unit: f or m");
  if (!(args.max_dt.getValue() >= 0)) throw std::invalid_argument("--max-dt must be >= 0");
  if (!(args.delta.getValue() > 0)) throw std::invalid_argument("--delta must be > 0");
  const auto mode = rvwo::apps::parseAlignment(args.align.getValue());
  const int block = args.first_block.getValue() ? 1 : 0;
  const auto ref = rvwo::apps::readTum(args.gt.getValue(), block);
  const auto e = rvwo::apps::readTum(args.est.getValue(), block);
  const auto pairs = rvwo::apps::associate(ref, e, args.max_dt.getValue());
  if (pairs.size() < 3) {
    throw std::runtime_error("only " + std::to_string(pairs.size()) + " poses pair up within " +
                             std::to_string(args.max_dt.getValue()) + " s: are both files on the same clock?");
  }
  const bool metres = args.unit.getValue() == "m";
  const auto a = rvwo::apps::ate(ref, e, pairs, mode);
  const auto r = rvwo::apps::rpe(ref, e, pairs, args.delta.getValue(), metres, args.from_ref.getValue());
  const double path = rvwo::apps::pathLength(ref, pairs);
  if (r.stats.n == 0) {
    char what[160];
    std::snprintf(what, sizeof what,
                  "--delta %g %s spans no pair of poses (%zu poses paired over %.3f m): give a shorter one",
                  args.delta.getValue(), metres ? "m" : "frames", pairs.size(), path);
    throw std::invalid_argument(what);
  }

  std::printf("rvwo-eval: %zu of %zu ground-truth poses paired with %zu estimated (max dt %.3f s), path %.3f m\n",
              pairs.size(), ref.size(), e.size(), args.max_dt.getValue(), path);
  std::printf("alignment %s: scale %.6f, translation (%.4f, %.4f, %.4f)\n", args.align.getValue().c_str(),
              a.alignment.s, a.alignment.t.x(), a.alignment.t.y(), a.alignment.t.z());
  printStats("ATE", a.stats, "m");
  if (path > 0) std::printf("ATE rmse is %.3f %% of the path\n", 100 * a.stats.rmse / path);
  char rpe_name[64];
  std::snprintf(rpe_name, sizeof rpe_name, "RPE (delta %g %s)", args.delta.getValue(), metres ? "m" : "frames");
  printStats(rpe_name, r.stats, "m");
  if (!args.json.getValue().empty()) writeJson(args.json.getValue(), a, r, args, pairs.size(), path);
  if (!args.plot.getValue().empty()) writePlot(args.plot.getValue(), a, args.align.getValue());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return rvwo::apps::runApp("rvwo-eval", [&] {
    EvalArgs args;
    if (const auto status = rvwo::apps::parseCommandLine(args.cmd, argc, argv)) return *status;
    return evaluate(args);
  });
}
