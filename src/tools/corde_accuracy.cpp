// corde_accuracy: accuracy against cost of the explicit rod (V8 of docs/validation_references.md).
// Sweeps the number of elements N and the time step (fractions of critical_time_step()) on the
// suddenly loaded cantilever with both clamps, and writes one CSV row per run (plot:
// scripts/plot_accuracy.py).
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "cantilever_step.h"

namespace {

const char* kUsage =
    "usage: corde_accuracy [--quick] [--out FILE.csv] [--elements 10,20,...]\n"
    "                      [--fractions 0.9,0.5,...] [--periods P]\n"
    "  --quick        N = 10, 20 at 0.9 of the critical step (a few seconds)\n"
    "  --out FILE     CSV output (default accuracy.csv)\n"
    "  --elements L   comma-separated N (default 10,20,40,80)\n"
    "  --fractions L  comma-separated h / critical step (default 0.9,0.5,0.25,0.1)\n"
    "  --periods P    compared history in periods of mode 1 (default 5)\n";

bool parse_list(const std::string& s, std::vector<double>* out) {
  out->clear();
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (end == item.c_str() || *end != '\0' || !(v > 0.0)) return false;
    out->push_back(v);
  }
  return !out->empty();
}

int usage_error(const std::string& msg) {
  std::fprintf(stderr, "corde_accuracy: %s\n%s", msg.c_str(), kUsage);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> elements{10, 20, 40, 80}, fractions{0.9, 0.5, 0.25, 0.1};
  std::string out_path = "accuracy.csv";
  double periods = 5.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::printf("%s", kUsage);
      return 0;
    } else if (a == "--quick") {
      elements = {10, 20};
      fractions = {0.9};
    } else if (a == "--out" || a == "--elements" || a == "--fractions" || a == "--periods") {
      if (i + 1 >= argc) return usage_error(a + " needs a value");
      const std::string v = argv[++i];
      if (a == "--out") out_path = v;
      if (a == "--elements" && !parse_list(v, &elements)) return usage_error("bad --elements");
      if (a == "--fractions" && !parse_list(v, &fractions)) return usage_error("bad --fractions");
      if (a == "--periods" && !(std::atof(v.c_str()) > 0.0)) return usage_error("bad --periods");
      if (a == "--periods") periods = std::atof(v.c_str());
    } else {
      return usage_error("unknown argument " + a);
    }
  }
  FILE* out = std::fopen(out_path.c_str(), "w");
  if (!out) return usage_error("cannot write " + out_path);
  std::fprintf(out,
               "method,clamp,elements,step_fraction,h,steps,simulated_s,cpu_s,cpu_per_sim_s,"
               "cpu_per_frame_us,error_rms,error_max,error_rms_timoshenko,tip_error_rms_over_L\n");
  for (const bool ghost : {false, true}) {
    for (const double n : elements) {
      for (const double f : fractions) {
        corde::v8::StepCase c;
        c.elements = static_cast<int>(n);
        c.step_fraction = f;
        c.ghost_clamp = ghost;
        c.periods = periods;
        const corde::v8::StepResult r = corde::v8::run_step_case(c);
        const double per_sim = r.cpu_seconds / r.simulated_seconds;
        // cpu_per_frame_us: CPU per 2 ms of simulated time, the unit of docs/peers.md's tables.
        std::fprintf(out,
                     "split_rotation,%s,%d,%g,%.6e,%ld,%.6f,%.6f,%.6e,%.4f,%.6e,%.6e,%.6e,%.6e\n",
                     ghost ? "ghost" : "natural", c.elements, f, r.h, r.steps, r.simulated_seconds,
                     r.cpu_seconds, per_sim, per_sim * 2e-3 * 1e6, r.error_rms, r.error_max,
                     r.error_rms_timoshenko, r.error_rms * r.delta);
        std::fflush(out);
        std::fprintf(stderr,
                     "%-7s N=%3d h=%.3g (%.2f crit): error %.3e (Timoshenko %.3e), "
                     "CPU %.3f s per simulated s\n",
                     ghost ? "ghost" : "natural", c.elements, r.h, f, r.error_rms,
                     r.error_rms_timoshenko, per_sim);
      }
    }
  }
  std::fclose(out);
  return 0;
}
