// The figures the desktop app's scripted runs print (--quit-after's
// summary line, --orbit-benchmark): memory, where it is, percentiles.
#ifndef SWEEPSCAN_APP_GUI_FIGURES_H_
#define SWEEPSCAN_APP_GUI_FIGURES_H_

#include <nlohmann/json.hpp>
#include <vector>

namespace sweepscan::ui {
class MainWindow;
}  // namespace sweepscan::ui

namespace sweepscan::app {

// A field of /proc/self/status in MiB: VmRSS (resident now), VmHWM (peak).
double StatusMiB(const char* field);
double ResidentMiB();

// Where the memory is: the cloud store's resident payloads, the points in
// VTK's arrays (both levels), the C++ heap in use and free (kept by malloc
// for reuse), the resident set's anonymous and file-backed parts (the
// libraries, mapped files), and how often the view waited for the driver
// (--draw-pace).
nlohmann::json MemoryBreakdown(ui::MainWindow* window);

// The value at fraction `p` of the sorted values (0: least, 1: most), 0 for none.
double Percentile(std::vector<double> v, double p);

}  // namespace sweepscan::app

#endif  // SWEEPSCAN_APP_GUI_FIGURES_H_
