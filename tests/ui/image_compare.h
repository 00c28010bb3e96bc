// Comparing rendered images (the view's progressive passes against a
// one-frame render).
#ifndef SWEEPSCAN_TESTS_UI_IMAGE_COMPARE_H_
#define SWEEPSCAN_TESTS_UI_IMAGE_COMPARE_H_

#include <QImage>
#include <algorithm>
#include <cstdlib>

namespace sweepscan::testing {

// Pixels that differ by more than a grey level or two in some channel.
inline size_t DifferingPixels(const QImage& a, const QImage& b) {
  const QImage x = a.convertToFormat(QImage::Format_RGB32), y = b.convertToFormat(QImage::Format_RGB32);
  if (x.size() != y.size()) return static_cast<size_t>(x.width()) * x.height();
  size_t n = 0;
  for (int r = 0; r < x.height(); ++r) {
    const QRgb* p = reinterpret_cast<const QRgb*>(x.constScanLine(r));
    const QRgb* q = reinterpret_cast<const QRgb*>(y.constScanLine(r));
    for (int c = 0; c < x.width(); ++c) {
      const int d = std::max({std::abs(qRed(p[c]) - qRed(q[c])), std::abs(qGreen(p[c]) - qGreen(q[c])),
                              std::abs(qBlue(p[c]) - qBlue(q[c]))});
      n += d > 2 ? 1 : 0;
    }
  }
  return n;
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_IMAGE_COMPARE_H_
