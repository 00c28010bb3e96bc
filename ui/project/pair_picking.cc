#include "ui/project/pair_picking.h"

#include <QApplication>
#include <QKeyEvent>
#include <QUndoCommand>
#include <QWidget>

#include "ui/own_window.h"
#include "ui/project/project_controller.h"

namespace sweepscan::ui {
namespace {

QString Id(const std::string& id) { return QString::fromStdString(id); }

// One pick added or undone: the picks before and after (a few points).
class PicksCommand : public QUndoCommand {
 public:
  PicksCommand(PairPicking* picking, std::vector<PairPicking::Pick> after, const QString& text)
      : picking_(picking), before_(picking->picks()), after_(std::move(after)) {
    setText(text);
  }
  void redo() override { picking_->SetPicks(after_); }
  void undo() override { picking_->SetPicks(before_); }

 private:
  PairPicking* picking_;
  std::vector<PairPicking::Pick> before_, after_;
};

}  // namespace

// Apart from any session colour (the defaults are Tableau's), and from each other.
const QColor PairPicking::kSourceColor(255, 214, 64);
const QColor PairPicking::kTargetColor(40, 230, 255);

PairPicking::PairPicking(ProjectController* controller, CloudView* view, QWidget* window)
    : QObject(controller), controller_(controller), view_(view), window_(window) {
  // Markers follow the session's drawn pose (beside the project until its
  // cloud is built) and the project's edits.
  connect(controller_, &ProjectController::cloudsChanged, this, [this] {
    if (active()) ShowMarkers();
  });
  connect(controller_->document(), &ProjectDocument::changed, this, [this] {
    if (!active()) return;
    // Its session or reference gone (removed, an addition undone) or the
    // reference no longer placed: nothing left to pick in, said as it is.
    const Project& p = controller_->document()->project();
    const int r = p.Find(reference_);
    QString gone;
    if (p.Find(session_) < 0) {
      gone = tr("'%1' is no longer in the project").arg(Id(session_));
    } else if (r < 0) {
      gone = tr("'%1' is no longer in the project").arg(Id(reference_));
    } else if (!p.sessions[r].project_from_session) {
      gone = tr("'%1' is no longer placed").arg(Id(reference_));
    }
    if (gone.isEmpty()) {
      ShowMarkers();
      return;
    }
    Abandon(gone);
  });
  connect(controller_->jobs(), &ProjectJobs::finished, this, [this] {
    if (active()) emit changed();  // Align may be possible now.
  });
  connect(controller_, &ProjectController::alignFinished, this, [this](bool placed, const QString&) {
    if (!aligning_) return;
    aligning_ = false;
    if (placed) {
      End();  // The placement is on the window's stack; the picks are done.
    } else {
      emit changed();  // Refused or cancelled: the picks stay to mend.
    }
  });
}

// The picks' stack clears itself as it is destroyed, which would tell the
// pick box (PairPickBox::Refresh -> can_align -> the controller's jobs) after
// the controller's members are gone: it says nothing now.
PairPicking::~PairPicking() {
  qApp->removeEventFilter(this);
  undo_.blockSignals(true);
}

bool PairPicking::Start(const std::string& id, const std::string& reference) {
  const Project& p = controller_->document()->project();
  const int i = p.Find(id), r = p.Find(reference);
  if (controller_->jobs()->running() || i < 0 || r < 0 || i == r || i == p.Anchor() ||
      !p.sessions[r].project_from_session) {
    return false;
  }
  if (active()) End();
  session_ = id;
  reference_ = reference;
  picks_.clear();
  undo_.clear();
  qApp->installEventFilter(this);
  controller_->SetPreview({id, reference});
  ShowMarkers();
  emit message(instruction());
  emit changed();
  return true;
}

void PairPicking::Cancel() {
  if (!active()) return;
  if (aligning_) controller_->Cancel();
  aligning_ = false;
  End();
  emit message(tr("Pair picking cancelled: the project is unchanged"));
}

void PairPicking::Abandon(const QString& why) {
  if (!active()) return;
  if (aligning_) controller_->Cancel();
  aligning_ = false;
  End();
  emit message(tr("Pair picking ended: %1; its picks are dropped").arg(why));
}

void PairPicking::End() {
  qApp->removeEventFilter(this);
  session_.clear();
  reference_.clear();
  picks_.clear();
  undo_.clear();
  view_->SetMarkers({});
  controller_->SetPreview({});
  emit changed();
}

bool PairPicking::AddPick(const PickHit& hit) {
  if (!active() || aligning_) return false;
  const bool want_target = !picks_.empty() && !picks_.back().has_target;
  const std::string& want = want_target ? reference_ : session_;
  const std::string got = hit.layer.toStdString();
  if (got != want) {
    if (got.empty() || (got != session_ && got != reference_)) {
      emit message(tr("That point is not in '%1': Shift + click in '%1'").arg(Id(want)));
    } else if (want_target) {
      emit message(tr("Now the same point in '%1' (cyan)").arg(Id(want)));
    } else {
      // A pair starts in the session: there is nothing in it to match yet.
      emit message(tr("A pair starts in '%1' (yellow); then the same point in '%2' (cyan)")
                       .arg(Id(session_), Id(reference_)));
    }
    return false;
  }
  std::vector<Pick> after = picks_;
  if (want_target) {
    after.back().target = hit.local;
    after.back().has_target = true;
  } else {
    Pick pick;
    pick.source = hit.local;
    after.push_back(pick);
  }
  undo_.push(new PicksCommand(this, after, want_target ? tr("pick %1 in '%2'").arg(after.size()).arg(Id(reference_))
                                                       : tr("pick %1 in '%2'").arg(after.size()).arg(Id(session_))));
  emit message(instruction());
  return true;
}

void PairPicking::SetPicks(const std::vector<Pick>& picks) {
  picks_ = picks;
  ShowMarkers();
  emit changed();
}

std::vector<PointPair> PairPicking::pairs() const {
  std::vector<PointPair> out;
  for (const Pick& p : picks_) {
    if (p.has_target) out.push_back({p.source, p.target});
  }
  return out;
}

bool PairPicking::can_align() const {
  return active() && !aligning_ && pairs().size() >= static_cast<size_t>(kMinPairs) &&
         !controller_->jobs()->running();
}

bool PairPicking::Align(bool hold_free) {
  if (!can_align()) return false;
  hardware::SessionRegistrationOptions options;
  options.pairs = pairs();
  options.hold_free = hold_free;
  aligning_ = controller_->Align(session_, reference_, options);
  emit changed();
  return aligning_;
}

QString PairPicking::instruction() const {
  if (!active()) return QString();
  if (aligning_) return tr("Aligning '%1' to '%2' by %3 pairs…").arg(Id(session_), Id(reference_)).arg(pairs().size());
  const size_t n = pairs().size();
  if (!picks_.empty() && !picks_.back().has_target) {
    return tr("Pair %1: Shift + click the same point in '%2' (cyan).").arg(picks_.size()).arg(Id(reference_));
  }
  QString text = tr("Pair %1: Shift + click a point in '%2' (yellow): a door jamb, a corner.")
                     .arg(n + 1)
                     .arg(Id(session_));
  if (n >= static_cast<size_t>(kMinPairs)) {
    text += tr(" Or Align by pairs.");
  } else {
    text += tr(" At least %1 pairs, not on one line.").arg(kMinPairs);
  }
  return text;
}

void PairPicking::ShowMarkers() {
  const Project shown = controller_->ShownProject();
  const int i = shown.Find(session_), r = shown.Find(reference_);
  std::vector<CloudView::Marker> markers;
  for (size_t k = 0; k < picks_.size() && i >= 0 && r >= 0; ++k) {
    const Pick& p = picks_[k];
    const QString number = QString::number(k + 1);
    const bool waiting = !p.has_target;
    if (shown.sessions[i].project_from_session) {
      markers.push_back({*shown.sessions[i].project_from_session * p.source, kSourceColor, waiting, number});
    }
    if (p.has_target && shown.sessions[r].project_from_session) {
      markers.push_back({*shown.sessions[r].project_from_session * p.target, kTargetColor, false, number});
    }
  }
  view_->SetMarkers(markers);
}

bool PairPicking::eventFilter(QObject* watched, QEvent* event) {
  const QEvent::Type type = event->type();
  if (!active() || (type != QEvent::KeyPress && type != QEvent::ShortcutOverride)) {
    return QObject::eventFilter(watched, event);
  }
  // Only keys meant for this window (not for a dialog on top of it).
  auto* w = qobject_cast<QWidget*>(watched);
  if (w == nullptr || !InWindowOf(w, window_)) return QObject::eventFilter(watched, event);
  auto* key = static_cast<QKeyEvent*>(event);
  const bool esc = key->key() == Qt::Key_Escape && key->modifiers() == Qt::NoModifier;
  const bool undo = key->matches(QKeySequence::Undo);
  const bool redo = key->matches(QKeySequence::Redo) ||
                    (key->key() == Qt::Key_Z && key->modifiers() == (Qt::ControlModifier | Qt::ShiftModifier));
  if (!esc && !undo && !redo) return QObject::eventFilter(watched, event);
  // The override keeps the Edit menu's Ctrl+Z from undoing a project edit
  // while picks are being made; the press does the pick's undo.
  event->accept();
  if (type == QEvent::KeyPress && !key->isAutoRepeat()) {
    if (esc) {
      Cancel();
    } else if (aligning_) {
      // The picks are in use by the job.
    } else if (undo) {
      undo_.undo();
      emit message(instruction());
    } else {
      undo_.redo();
      emit message(instruction());
    }
  }
  return true;
}

}  // namespace sweepscan::ui
