// Runs a function on another thread's event loop and waits for it: how the
// workspace creates, starts and queries objects that must live on the I/O
// or robot thread (their timers and sockets belong to the thread that
// created them).
#ifndef SWEEPSCAN_UI_WORKSPACE_THREAD_CALL_H_
#define SWEEPSCAN_UI_WORKSPACE_THREAD_CALL_H_

#include <QMetaObject>
#include <QObject>
#include <QThread>
#include <functional>

namespace sweepscan::ui {

// `thread` must be running and must not be the calling thread.
inline void CallOnThread(QThread* thread, const std::function<void()>& call) {
  // A context object living on `thread` routes the call to its event loop;
  // it is detached again before it is destroyed here.
  QObject context;
  context.moveToThread(thread);
  QMetaObject::invokeMethod(
      &context,
      [&] {
        call();
        context.moveToThread(nullptr);
      },
      Qt::BlockingQueuedConnection);
}

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_WORKSPACE_THREAD_CALL_H_
