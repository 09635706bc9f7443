// The automatic choices depend on the scene only: with the thread CPU clock replaced by one that
// runs slow and jerky (as on a loaded machine), every shipped scene, and every shipped scene
// with `integrator: auto`, makes the same choices, and the choices read that clock not once.
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <time.h>

#include <filesystem>
#include <string>
#include <vector>

#include "corde_sim/scene/scene.h"

namespace {

bool g_slow = false;   // distort the thread CPU clock
long g_reads = 0;      // reads of the thread CPU clock
long g_offset_ns = 0;  // added to every read while slow

}  // namespace

// Interposed for this test executable (the library is linked in statically): every read of
// CLOCK_THREAD_CPUTIME_ID is counted, and while g_slow each one is 1 ms later than the real
// clock says beyond the last, as if the thread had been starved of cache and cores.
extern "C" int clock_gettime(clockid_t id, struct timespec* ts) noexcept {
  using Fn = int (*)(clockid_t, struct timespec*);
  static const Fn real = reinterpret_cast<Fn>(dlsym(RTLD_NEXT, "clock_gettime"));
  const int r = real(id, ts);
  if (r != 0 || id != CLOCK_THREAD_CPUTIME_ID) return r;
  ++g_reads;
  if (g_slow) {
    g_offset_ns += 1000000;
    const long ns = ts->tv_nsec + g_offset_ns;
    ts->tv_sec += ns / 1000000000;
    ts->tv_nsec = ns % 1000000000;
  }
  return r;
}

namespace corde {
namespace {

struct Choice {
  std::vector<std::string> notes;
  Integrator integrator;
  double time_step;
};

Choice choose(const std::string& path, const std::vector<std::string>& overrides, bool slow) {
  g_slow = slow;
  const Scene s = load_scene(path, overrides);
  g_slow = false;
  return {s.notes, s.world.integrator, s.world.time_step};
}

TEST(AutoChoiceClock, ShippedScenesChooseTheSameOnASlowClockAndReadNoClock) {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(
           std::filesystem::path(CORDE_SIM_SOURCE_DIR) / "config/scenes"))
    if (e.path().extension() == ".yaml") files.push_back(e.path().string());
  ASSERT_FALSE(files.empty());
  int autos = 0;
  for (const std::string& f : files) {
    for (const std::vector<std::string>& o :
         {std::vector<std::string>{}, std::vector<std::string>{"integrator=auto"}}) {
      SCOPED_TRACE(f + (o.empty() ? "" : " integrator=auto"));
      const Choice idle = choose(f, o, false);
      const long before = g_reads;
      const Choice slow = choose(f, o, true);
      EXPECT_EQ(g_reads, before) << "the choice read the thread CPU clock";
      EXPECT_EQ(idle.integrator, slow.integrator);
      EXPECT_EQ(idle.time_step, slow.time_step);
      EXPECT_EQ(idle.notes, slow.notes);  // the reasons too
      autos += !o.empty();
    }
  }
  EXPECT_GT(autos, 10);
}

}  // namespace
}  // namespace corde
