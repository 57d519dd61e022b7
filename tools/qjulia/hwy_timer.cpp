// libhwy (Highway's shared library) calibrates the timer of its benchmark helpers in a static
// initializer: about 5 ms of busy-waiting at the start of every process that loads it (a third
// of `qjulia --version`'s 15-20 ms of CPU; `perf record`). qjulia uses Highway only for its
// dispatch (SupportedTargets, GetChosenTarget), never its timers. The initializer calls the
// function through the dynamic linker, so this definition in the executable answers instead
// and the calibration does not run. Linked into the executables only (an archive member would
// never be pulled in: nothing in them calls it); nothing else in a process may use Highway's
// timers.
#include <cstdint>

namespace hwy::platform {

std::uint64_t TimerResolution() { return 1; }

}  // namespace hwy::platform
