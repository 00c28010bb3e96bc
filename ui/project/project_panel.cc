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
#include <QToolButton>
#include <QTreeWidget>
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
  QString text = QObject::tr("%1 to %2 · rms %3 mm · overlap %4 % · 1σ %5 mm / %6°")
                     .arg(QString::fromStdString(e.method), QString::fromStdString(e.reference))
                     .arg(e.rms_m * 1e3, 0, 'f', 1)
                     .arg(std::lround(e.overlap * 100))
                     .arg(e.SigmaTranslation() * 1e3, 0, 'f', 1)
                     .arg(e.SigmaRotation() * 180.0 / M_PI, 0, 'f', 3);
  if (!e.free_direction.isZero()) text += QObject::tr(" · free along a corridor");
  return text;
}

}  // namespace

ProjectPanel::ProjectPanel(ProjectController* controller, QWidget* parent)
    : QWidget(parent), controller_(controller) {
  auto* layout = new QVBoxLayout(this);
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
  progress_ = new QProgressBar;
  progress_->setTextVisible(true);
  progress_->setVisible(false);
  edit_row->addWidget(progress_, 2);
  cancel_ = new QToolButton;
  cancel_->setObjectName(QStringLiteral("projectCancel"));
  cancel_->setText(tr("Cancel"));
  cancel_->setVisible(false);
  connect(cancel_, &QToolButton::clicked, controller_, &ProjectController::Cancel);
  edit_row->addWidget(cancel_);
  layout->addLayout(edit_row);

  status_ = new QLabel;
  status_->setWordWrap(true);
  status_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(status_);
  connect(controller_, &ProjectController::alignFinished, this,
          [this](bool, const QString& text) {
            status_->setText(text);
            status_is_progress_ = false;
          });
  Refresh();
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
    progress_->setFormat(what);
    progress_->setToolTip(what);
    progress_->setRange(0, fraction < 0 ? 0 : 1000);
    if (fraction >= 0) progress_->setValue(static_cast<int>(1000 * fraction));
    status_->setText(what + QStringLiteral("…"));
    status_is_progress_ = true;
  } else if (status_is_progress_) {
    status_->clear();  // Done: an alignment's outcome stays, a progress text goes.
    status_is_progress_ = false;
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
  const Project& p = controller_->document()->project();
  const int i = p.Find(id);
  QMenu* align = menu->addMenu(tr("Align to"));
  for (const ProjectSession& s : p.sessions) {
    if (s.id == id || !s.project_from_session || p.PlacedThrough(s.id, id)) continue;
    const std::string reference = s.id;
    align->addAction(QString::fromStdString(reference), this,
                     [this, id, reference] { controller_->Align(id, reference); });
  }
  align->setEnabled(i >= 0 && i != p.Anchor() && !align->isEmpty() && !controller_->busy());
  menu->addAction(tr("Colour…"), this, [this, id] { ChooseColor(id); });
  menu->addAction(tr("Show Only This"), this, [this, id] { controller_->ShowOnly(id); });
  menu->addSeparator();
  menu->addAction(tr("Remove from Project"), this, [this, id] { controller_->RemoveSession(id); });
  return menu;
}

}  // namespace sweepscan::ui
