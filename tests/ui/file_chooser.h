// Answers the app's next file chooser (QFileDialog's own dialog, as under
// Xvfb): types `name` into its name field and accepts, as an operator
// would, first choosing the file type `filter` if one is given. Where it
// opened, the name it suggested and the file type it had chosen go to
// `opened_in`, `suggested` and `suggested_filter`, and `answered` becomes
// true, if given. Call it before the
// action that opens the chooser: it waits for the chooser on the event
// loop the chooser's exec() runs.
#ifndef SWEEPSCAN_TESTS_UI_FILE_CHOOSER_H_
#define SWEEPSCAN_TESTS_UI_FILE_CHOOSER_H_

#include <gtest/gtest.h>

#include <QApplication>
#include <QDir>
#include <QFileDialog>
#include <QLineEdit>
#include <QMetaObject>
#include <QString>
#include <QTimer>

namespace sweepscan::testing {

inline void AnswerFileChooser(const QString& name, bool* answered = nullptr,
                              QString* opened_in = nullptr, QString* suggested = nullptr,
                              const QString& filter = QString(),
                              QString* suggested_filter = nullptr) {
  QTimer::singleShot(50, [=] {
    auto* chooser = qobject_cast<QFileDialog*>(QApplication::activeModalWidget());
    if (chooser == nullptr) {
      AnswerFileChooser(name, answered, opened_in, suggested, filter, suggested_filter);
      return;
    }
    auto* field = chooser->findChild<QLineEdit*>(QStringLiteral("fileNameEdit"));
    ASSERT_NE(field, nullptr);
    if (opened_in != nullptr) *opened_in = chooser->directory().absolutePath();
    if (suggested != nullptr) *suggested = field->text();
    if (suggested_filter != nullptr) *suggested_filter = chooser->selectedNameFilter();
    if (!filter.isEmpty()) chooser->selectNameFilter(filter);
    field->setText(name);
    QMetaObject::invokeMethod(chooser, "accept", Qt::QueuedConnection);
    if (answered != nullptr) *answered = true;
  });
}

}  // namespace sweepscan::testing

#endif  // SWEEPSCAN_TESTS_UI_FILE_CHOOSER_H_
