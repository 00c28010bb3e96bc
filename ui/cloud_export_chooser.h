// The save dialog of a cloud export (File > Export Cloud and Export Project
// Cloud): LAS 1.4, PLY or PCD, opened in the folder last exported to (else
// beside what is exported) on the format last chosen (a surveyor exports
// LAS every time), both kept in QSettings (export/dir, export/suffix). A
// name typed without a suffix takes the chosen format's.
//
// GUI thread.
#ifndef SWEEPSCAN_UI_CLOUD_EXPORT_CHOOSER_H_
#define SWEEPSCAN_UI_CLOUD_EXPORT_CHOOSER_H_

#include <QString>

class QWidget;

namespace sweepscan::ui {

// `base_name`: the name offered, without its suffix ("" for none);
// `beside`: the folder offered when nothing was exported yet. Returns the
// path chosen, "" if cancelled.
QString ChooseCloudExport(QWidget* parent, const QString& title, const QString& base_name,
                          const QString& beside);

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_CLOUD_EXPORT_CHOOSER_H_
