// The figures of the desktop app's scripted runs (app/gui_figures.h).
#include "app/gui_figures.h"

#include <malloc.h>

#include <QByteArray>
#include <QFile>
#include <algorithm>

#include "core/cloud/cloud_pager.h"
#include "ui/main_window.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::app {

double StatusMiB(const char* field) {
  QFile f(QStringLiteral("/proc/self/status"));
  if (!f.open(QIODevice::ReadOnly)) return 0.0;
  const QByteArray key = QByteArray(field) + ':';
  for (const QByteArray& line : f.readAll().split('\n')) {
    if (line.startsWith(key)) {
      return line.mid(key.size()).trimmed().split(' ')[0].toDouble() / 1024.0;
    }
  }
  return 0.0;
}
double ResidentMiB() { return StatusMiB("VmRSS"); }

nlohmann::json MemoryBreakdown(ui::MainWindow* window) {
  const struct mallinfo2 heap = mallinfo2();
  return {{"store_mib", CloudPager::Default().resident_bytes() / 1048576.0},
          {"store_unpacked_mib", CloudPager::Default().unpacked_bytes() / 1048576.0},
          {"store_paged_out_chunks", CloudPager::Default().paged_out_chunks()},
          {"vtk_points", window->view()->vtk_point_count()},
          {"heap_in_use_mib", (heap.uordblks + heap.hblkhd) / 1048576.0},
          {"heap_free_mib", heap.fordblks / 1048576.0},
          {"rss_anon_mib", StatusMiB("RssAnon")},
          {"rss_file_mib", StatusMiB("RssFile")},
          {"peak_rss_mib", StatusMiB("VmHWM")},
          {"draw_waits", window->view()->draw_waits()}};
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

}  // namespace sweepscan::app
