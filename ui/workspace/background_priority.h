// Background jobs (opening a session or a project, aligning, calibrating,
// evaluating, building a plan) run at a lower scheduling priority than the
// GUI thread: on a 2-core laptop a job on both cores (oneTBB) and the
// software renderer's threads would otherwise share the CPU evenly with the
// GUI thread, and a frame that takes 150 ms alone took 0.5-1.5 s (the
// project UI tests' event-loop gaps under ctest -j2). The job loses nothing
// when the GUI is idle; when it is not, the GUI goes first.
#ifndef SWEEPSCAN_UI_WORKSPACE_BACKGROUND_PRIORITY_H_
#define SWEEPSCAN_UI_WORKSPACE_BACKGROUND_PRIORITY_H_

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace sweepscan::ui {

// Call first thing on a job thread. Linux keeps a nice value per thread,
// and threads it starts (oneTBB's workers, when the job is the first to use
// oneTBB) inherit it. 10 of 19: well behind the GUI, not starved.
inline void LowerThisThreadsPriority() {
#ifdef __linux__
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
#endif
}

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_WORKSPACE_BACKGROUND_PRIORITY_H_
