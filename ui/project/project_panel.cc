#include "ui/project/project_panel.h"

#include <QColorDialog>
#include <QComboBox>
#include <QFileDialog>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QMenu>
#include <QPainter>
#include <QPixmap>
#include <QProgressBar>
#include <QPushButton>
#include <QScrollArea>
#include <QToolButton>
#include <QTreeWidget>
#include <QUndoStack>
#include <QVBoxLayout>

#include "ui/project/pair_pick_box.h"
#include "ui/project/pair_picking.h"
#include "ui/project/project_controller.h"

namespace sweepscan::ui {
namespace {

constexpr int kIdRole = Qt::UserRole;

QIcon Swatch(const QString& color) {
  QPixmap pixmap(14, 14);
  pixmap.fill(Qt::transparent);
  QPainter p(&pixmap);
  p.setPen(QColor(40, 40, 40));
  p.setBrush(QColor(color));
  p.drawRect(0, 0, 13, 13);
  return QIcon(pixmap);
}

// Where a session is, as the operator judges it: the anchor, how it was
// placed and how well, or not at all.
QString Placement(const ProjectSession& s, bool* placed) {
  *placed = s.project_from_session.has_value();
  if (!*placed) return QObject::tr("not placed");
  const RegistrationEvidence& e = s.registration;
  if (e.method == "anchor") return QObject::tr("anchor (the project's frame)");
  // Typed in, or its reference dropped: the zero covariance means unknown.
  if (e.method == "manual") return QObject::tr("manual · not measured");
  // On three lines: on one, the dock's width cut it after the rms, and the
  // overlap and the uncertainty were only in the tooltip.
  QString text = QObject::tr("%1 to %2\nrms %3 mm · overlap %4 %\n1σ %5 mm / %6°")
                     .arg(QString::fromStdString(e.method), QString::fromStdString(e.reference))
                     .arg(e.rms_m * 1e3, 0, 'f', 1)
                     .arg(std::lround(e.overlap * 100))
                     .arg(e.SigmaTranslation() * 1e3, 0, 'f', 1)
                     .arg(e.SigmaRotation() * 180.0 / M_PI, 0, 'f', 3);
  if (!e.free_direction.isZero()) text += QObject::tr("\nfree along a corridor");
  return text;
}

}  // namespace

ProjectPanel::ProjectPanel(ProjectController* controller, QWidget* parent)
    : QWidget(parent), controller_(controller) {
  // The content scrolls inside the dock rather than being squeezed: the
  // pair-picking box and a long status (a refusal's reason) need more
  // height than the dock under the Drive panel has, and a squeezed layout
  // drew its wrapped labels over one another. Qt's scroll area gives the
  // content the height its wrapped labels need at the width it has
  // (heightForWidth), and the dock keeps its own size when the box comes
  // and goes (it grew with the box and stayed tall, squeezing the Drive
  // panel).
  auto* outer = new QVBoxLayout(this);
  outer->setContentsMargins(0, 0, 0, 0);
  auto* scroll = new QScrollArea;
  scroll->setObjectName(QStringLiteral("projectScroll"));
  scroll->setFrameShape(QFrame::NoFrame);
  scroll->setWidgetResizable(true);
  scroll->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  outer->addWidget(scroll);
  auto* content = new QWidget;
  auto* layout = new QVBoxLayout(content);
  name_ = new QLabel;
  name_->setWordWrap(true);
  layout->addWidget(name_);
  tree_ = new QTreeWidget;
  tree_->setObjectName(QStringLiteral("projectSessions"));
  tree_->setColumnCount(2);
  tree_->setHeaderLabels({tr("Session"), tr("Placement")});
  tree_->setRootIsDecorated(false);
  tree_->setContextMenuPolicy(Qt::CustomContextMenu);
  tree_->header()->setSectionResizeMode(0, QHeaderView::ResizeToContents);
  tree_->setMinimumHeight(110);
  layout->addWidget(tree_, 1);
  connect(tree_, &QTreeWidget::itemChanged, this, [this](QTreeWidgetItem* item, int column) {
    if (refreshing_ || column != 0) return;
    controller_->SetVisible(item->data(0, kIdRole).toString().toStdString(),
                            item->checkState(0) == Qt::Checked);
  });
  connect(tree_, &QTreeWidget::itemDoubleClicked, this, [this](QTreeWidgetItem* item, int) {
    ChooseColor(item->data(0, kIdRole).toString().toStdString());
  });
  connect(tree_, &QTreeWidget::itemSelectionChanged, this, &ProjectPanel::UpdateAlign);
  connect(tree_, &QTreeWidget::customContextMenuRequested, this, [this](const QPoint& at) {
    QTreeWidgetItem* item = tree_->itemAt(at);
    if (item == nullptr) return;
    QMenu* menu = ContextMenu(item->data(0, kIdRole).toString().toStdString());
    menu->setAttribute(Qt::WA_DeleteOnClose);
    menu->popup(tree_->viewport()->mapToGlobal(at));
  });

  auto* align_row = new QHBoxLayout;
  align_row->addWidget(new QLabel(tr("Align to")));
  reference_ = new QComboBox;
  reference_->setObjectName(QStringLiteral("projectReference"));
  reference_->setToolTip(tr("A placed session that sees some of the same walls"));
  align_row->addWidget(reference_, 1);
  align_ = new QPushButton(tr("Align"));
  align_->setObjectName(QStringLiteral("projectAlign"));
  align_->setToolTip(tr("Planes then ICP, as sweepscan-cli project align --session ID --to REF"));
  connect(align_, &QPushButton::clicked, this, [this] {
    controller_->Align(selected(), reference_->currentData().toString().toStdString());
    UpdateAlign();
  });
  align_row->addWidget(align_);
  pick_ = new QPushButton(tr("Pick Pairs…"));
  pick_->setObjectName(QStringLiteral("projectPickPairs"));
  pick_->setToolTip(tr("Shift + click the same points in this session and the reference, then align "
                       "by them: for what the planes refuse (a corridor)"));
  connect(pick_, &QPushButton::clicked, this, [this] {
    controller_->pair_picking()->Start(selected(), reference_->currentData().toString().toStdString());
  });
  align_row->addWidget(pick_);
  layout->addLayout(align_row);
  pair_box_ = new PairPickBox(controller_->pair_picking());
  layout->addWidget(pair_box_, 1);
  connect(controller_->pair_picking(), &PairPicking::changed, this, &ProjectPanel::UpdateAlign);

  auto* edit_row = new QHBoxLayout;
  add_ = new QPushButton(tr("Add Session…"));
  connect(add_, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(
        this, tr("Add a session folder (NAME.sweepscan)"),
        QFileInfo(controller_->document()->path()).absolutePath());
    if (!dir.isEmpty()) controller_->AddSession(dir);
  });
  edit_row->addWidget(add_);
  edit_row->addStretch(1);
  layout->addLayout(edit_row);
  // The progress on a row of its own, the dock's whole width: beside Add
  // Session its text ("Aligning 'b' to 'a': hypotheses") wrapped into two
  // cut-off lines.
  auto* progress_row = new QHBoxLayout;
  progress_ = new QProgressBar;
  progress_->setObjectName(QStringLiteral("projectProgress"));
  progress_->setTextVisible(true);
  progress_->setVisible(false);
  progress_->setSizePolicy(QSizePolicy::Ignored, QSizePolicy::Fixed);
  progress_row->addWidget(progress_, 1);
  cancel_ = new QToolButton;
  cancel_->setObjectName(QStringLiteral("projectCancel"));
  cancel_->setText(tr("Cancel"));
  cancel_->setVisible(false);
  connect(cancel_, &QToolButton::clicked, controller_, &ProjectController::Cancel);
  progress_row->addWidget(cancel_);
  layout->addLayout(progress_row);

  status_ = new QLabel;
  status_->setWordWrap(true);
  status_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(status_);
  scroll->setWidget(content);
  connect(controller_, &ProjectController::alignFinished, this, &ProjectPanel::ShowOutcome);
  // An outcome is true of the project as it was edited then: undone past
  // (or another project) it goes, redone it comes back (UpdateOutcome).
  connect(controller_->undo_stack(), &QUndoStack::indexChanged, this, &ProjectPanel::UpdateOutcome);
  connect(controller_->document(), &ProjectDocument::opened, this, [this] {
    outcome_.clear();
    outcome_command_ = nullptr;
    UpdateOutcome();
  });
  Refresh();
}

void ProjectPanel::ShowOutcome(bool placed, const QString& text) {
  const QUndoStack* undo = controller_->undo_stack();
  outcome_ = text;
  // A placement is the command on top of the stack now; a refusal or a
  // cancel changed nothing, and is said while the project is as it was
  // then (the same command on top).
  outcome_index_ = undo->index();
  outcome_command_ = outcome_index_ > 0 ? undo->command(outcome_index_ - 1) : nullptr;
  outcome_placed_ = placed;
  status_is_progress_ = false;
  UpdateOutcome();
}

void ProjectPanel::UpdateOutcome() {
  if (status_is_progress_) return;  // A job's progress; the outcome after it.
  const QUndoStack* undo = controller_->undo_stack();
  const QUndoCommand* top = undo->index() > 0 ? undo->command(undo->index() - 1) : nullptr;
  const bool applied = outcome_placed_ ? undo->index() >= outcome_index_ && outcome_index_ > 0 &&
                                             undo->command(outcome_index_ - 1) == outcome_command_
                                       : undo->index() == outcome_index_ && top == outcome_command_;
  status_->setText(!outcome_.isEmpty() && applied ? outcome_ : QString());
}

QTreeWidgetItem* ProjectPanel::item(const std::string& id) const {
  for (int i = 0; i < tree_->topLevelItemCount(); ++i) {
    QTreeWidgetItem* it = tree_->topLevelItem(i);
    if (it->data(0, kIdRole).toString().toStdString() == id) return it;
  }
  return nullptr;
}

std::string ProjectPanel::selected() const {
  const QList<QTreeWidgetItem*> items = tree_->selectedItems();
  return items.isEmpty() ? std::string() : items.front()->data(0, kIdRole).toString().toStdString();
}

void ProjectPanel::SelectSession(const std::string& id) {
  if (QTreeWidgetItem* it = item(id)) tree_->setCurrentItem(it);
}

void ProjectPanel::Refresh() {
  const ProjectDocument* doc = controller_->document();
  const Project& p = doc->project();
  const std::string keep = selected();
  refreshing_ = true;
  // Items are updated in place while the sessions are the same: a check
  // box's click ends in this Refresh (through its undo command) while Qt
  // is still inside that item's setData, so the item must outlive it.
  bool same = tree_->topLevelItemCount() == static_cast<int>(p.sessions.size());
  for (int i = 0; same && i < tree_->topLevelItemCount(); ++i) {
    same = tree_->topLevelItem(i)->data(0, kIdRole).toString().toStdString() == p.sessions[i].id;
  }
  if (!same) tree_->clear();
  for (size_t k = 0; k < p.sessions.size(); ++k) {
    const ProjectSession& s = p.sessions[k];
    QTreeWidgetItem* it = same ? tree_->topLevelItem(static_cast<int>(k)) : new QTreeWidgetItem(tree_);
    it->setData(0, kIdRole, QString::fromStdString(s.id));
    it->setText(0, QString::fromStdString(s.id));
    it->setFlags(it->flags() | Qt::ItemIsUserCheckable);
    it->setCheckState(0, s.visible ? Qt::Checked : Qt::Unchecked);
    it->setIcon(0, Swatch(QString::fromStdString(s.color)));
    it->setToolTip(0, tr("%1\nDouble-click: colour").arg(QString::fromStdString(s.path)));
    bool placed = false;
    it->setText(1, Placement(s, &placed));
    it->setToolTip(1, it->text(1));
    // Not placed, not drawn: said in the list, greyed.
    it->setForeground(1, placed ? tree_->palette().color(QPalette::Text) : QColor(150, 150, 150));
    const QString failure = controller_->load_failure(s.id);
    if (!failure.isEmpty()) {
      it->setText(1, tr("cannot load: %1").arg(failure));
      it->setToolTip(1, failure);
      it->setForeground(1, QColor(200, 40, 40));
    }
  }
  refreshing_ = false;
  if (!keep.empty()) SelectSession(keep);
  if (!doc->is_open()) {
    name_->setText(tr("No project. File > New Project… or Open Project… (Ctrl+Shift+O)."));
  } else {
    size_t placed = 0;
    for (const ProjectSession& s : p.sessions) placed += s.project_from_session ? 1 : 0;
    name_->setText(tr("<b>%1</b> · %2 session(s), %3 placed")
                       .arg(QString::fromStdString(p.name).toHtmlEscaped())
                       .arg(p.sessions.size())
                       .arg(placed));
  }
  add_->setEnabled(doc->is_open());
  UpdateAlign();
}

void ProjectPanel::UpdateAlign() {
  const Project& p = controller_->document()->project();
  const std::string id = selected();
  const QString current = reference_->currentData().toString();
  reference_->clear();
  // Not a session placed against this one (directly or through others):
  // it would move along with it.
  for (const ProjectSession& s : p.sessions) {
    if (s.id != id && s.project_from_session && !p.PlacedThrough(s.id, id)) {
      reference_->addItem(QString::fromStdString(s.id), QString::fromStdString(s.id));
    }
  }
  const int keep = reference_->findData(current);
  if (keep >= 0) reference_->setCurrentIndex(keep);
  const int i = p.Find(id);
  const bool can = i >= 0 && i != p.Anchor() && reference_->count() > 0 && !controller_->busy() &&
                   !controller_->pair_picking()->active();
  align_->setEnabled(can);
  pick_->setEnabled(can);
}

void ProjectPanel::ShowProgress(const QString& what, double fraction) {
  const bool on = fraction > -2.0;
  progress_->setVisible(on);
  cancel_->setVisible(on);
  if (on) {
    // As QProgressDialog shows it: the stage in words on the line below
    // (wrapped, whole), the bar its percentage. The stage in the bar too
    // said it twice, and a long one was cut off in the bar.
    progress_->setFormat(QStringLiteral("%p %"));
    progress_->setToolTip(what);
    progress_->setRange(0, fraction < 0 ? 0 : 1000);
    if (fraction >= 0) progress_->setValue(static_cast<int>(1000 * fraction));
    status_->setText(what + QStringLiteral("…"));
    status_is_progress_ = true;
  } else if (status_is_progress_) {
    status_is_progress_ = false;
    UpdateOutcome();  // Done: a progress text goes, an outcome still true stays.
  }
  UpdateAlign();
}

void ProjectPanel::ChooseColor(const std::string& id) {
  const Project& p = controller_->document()->project();
  const int i = p.Find(id);
  if (i < 0) return;
  const QColor color = QColorDialog::getColor(QColor(QString::fromStdString(p.sessions[i].color)), this,
                                              tr("Colour of '%1'").arg(QString::fromStdString(id)));
  if (color.isValid()) controller_->SetColor(id, color.name());
}

QMenu* ProjectPanel::ContextMenu(const std::string& id) {
  auto* menu = new QMenu(this);
  menu->setToolTipsVisible(true);  // Why an entry is disabled.
  const Project& p = controller_->document()->project();
  const int i = p.Find(id);
  // While pairs are picked, the project holds still as it does for the
  // panel's buttons: a session removed under the mode left it picking in
  // a session that no longer existed.
  const bool picking = controller_->pair_picking()->active();
  const QString not_now = tr("Not while pairs are picked: Esc or Cancel ends the picking first");
  const auto edit = [&](QAction* a) {
    if (!picking) return a;
    a->setEnabled(false);
    a->setToolTip(not_now);
    return a;
  };
  QMenu* align = menu->addMenu(tr("Align to"));
  for (const ProjectSession& s : p.sessions) {
    if (s.id == id || !s.project_from_session || p.PlacedThrough(s.id, id)) continue;
    const std::string reference = s.id;
    align->addAction(QString::fromStdString(reference), this,
                     [this, id, reference] { controller_->Align(id, reference); });
  }
  align->setEnabled(i >= 0 && i != p.Anchor() && !align->isEmpty() && !controller_->busy() &&
                    !picking);
  edit(menu->addAction(tr("Colour…"), this, [this, id] { ChooseColor(id); }));
  edit(menu->addAction(tr("Show Only This"), this, [this, id] { controller_->ShowOnly(id); }));
  menu->addSeparator();
  // Make Anchor: what core/project refuses (an unplaced session while
  // others are placed, one too far) is disabled with the reason.
  QAction* anchor =
      edit(menu->addAction(tr("Make Anchor"), this, [this, id] { controller_->MakeAnchor(id); }));
  Project anchored = p;
  const Status can_anchor = anchored.ChangeAnchor(id);
  if (i >= 0 && i == p.Anchor()) {
    anchor->setEnabled(false);
    anchor->setToolTip(tr("'%1' is the anchor: the project's frame is its start pose")
                           .arg(QString::fromStdString(id)));
  } else if (!can_anchor.ok()) {
    anchor->setEnabled(false);
    anchor->setToolTip(QString::fromStdString(can_anchor.message()));
  } else if (!picking) {
    anchor->setToolTip(tr("The project's frame becomes '%1''s start pose; the building stays as it "
                          "is, the placements between it and the anchor are turned round")
                           .arg(QString::fromStdString(id)));
  }
  QAction* remove = edit(menu->addAction(tr("Remove from Project"), this,
                                         [this, id] { controller_->RemoveSession(id); }));
  // What core/project would refuse (the anchor while others are placed
  // against it, a session others are placed against) is disabled with
  // the reason, not offered and then refused in a box.
  Project after = p;
  const Status can = after.RemoveSession(id);
  if (!can.ok()) {
    remove->setEnabled(false);
    remove->setToolTip(QString::fromStdString(can.message()));
  } else if (!picking && i == p.Anchor() && after.Anchor() >= 0) {
    remove->setToolTip(tr("'%1' becomes the anchor: the project's frame is its start pose")
                           .arg(QString::fromStdString(after.sessions[after.Anchor()].id)));
  }
  return menu;
}

}  // namespace sweepscan::ui
