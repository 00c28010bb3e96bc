#include "ui/project/pair_pick_box.h"

#include <QCheckBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QPushButton>
#include <QTreeWidget>
#include <QVBoxLayout>

#include "ui/project/pair_picking.h"

namespace sweepscan::ui {
namespace {

QString Xyz(const Eigen::Vector3d& p) {
  return QStringLiteral("%1, %2, %3").arg(p.x(), 0, 'f', 2).arg(p.y(), 0, 'f', 2).arg(p.z(), 0, 'f', 2);
}

QString Swatch(const QColor& c) {
  return QStringLiteral("<span style='color:%1'>■</span>").arg(c.name());
}

}  // namespace

PairPickBox::PairPickBox(PairPicking* picking, QWidget* parent) : QGroupBox(parent), picking_(picking) {
  setObjectName(QStringLiteral("pairPickBox"));
  auto* layout = new QVBoxLayout(this);
  instruction_ = new QLabel;
  instruction_->setWordWrap(true);
  layout->addWidget(instruction_);
  list_ = new QTreeWidget;
  list_->setObjectName(QStringLiteral("pairList"));
  list_->setColumnCount(3);
  list_->setRootIsDecorated(false);
  list_->header()->setSectionResizeMode(QHeaderView::ResizeToContents);
  list_->setMinimumHeight(90);
  layout->addWidget(list_, 1);
  hold_free_ = new QCheckBox(tr("Hold the free direction (a corridor)"));
  hold_free_->setObjectName(QStringLiteral("pairsHoldFree"));
  hold_free_->setChecked(true);
  hold_free_->setToolTip(
      tr("Where the walls leave a direction free (a bare corridor), ICP keeps the pairs' position "
         "along it and says so, instead of refusing (sweepscan-cli project align --hold-free)"));
  layout->addWidget(hold_free_);
  auto* row = new QHBoxLayout;
  undo_ = new QPushButton(tr("Undo Pick"));
  undo_->setObjectName(QStringLiteral("pairsUndo"));
  undo_->setToolTip(tr("Removes the last pick (Ctrl+Z while picking; Ctrl+Shift+Z redoes it)"));
  connect(undo_, &QPushButton::clicked, this, [this] { picking_->undo_stack()->undo(); });
  row->addWidget(undo_);
  row->addStretch(1);
  align_ = new QPushButton(tr("Align by Pairs"));
  align_->setObjectName(QStringLiteral("pairsAlign"));
  align_->setToolTip(tr("The pairs' rigid transform, then ICP, as sweepscan-cli project align --pairs"));
  connect(align_, &QPushButton::clicked, this, [this] { picking_->Align(hold_free_->isChecked()); });
  row->addWidget(align_);
  cancel_ = new QPushButton(tr("Cancel"));
  cancel_->setObjectName(QStringLiteral("pairsCancel"));
  cancel_->setToolTip(tr("Leaves pair picking; the project stays as it was (Esc)"));
  connect(cancel_, &QPushButton::clicked, picking_, &PairPicking::Cancel);
  row->addWidget(cancel_);
  layout->addLayout(row);
  connect(picking_, &PairPicking::changed, this, &PairPickBox::Refresh);
  connect(picking_->undo_stack(), &QUndoStack::indexChanged, this, &PairPickBox::Refresh);
  Refresh();
}

void PairPickBox::Refresh() {
  setVisible(picking_->active());
  if (!picking_->active()) return;
  const QString s = QString::fromStdString(picking_->session());
  const QString r = QString::fromStdString(picking_->reference());
  setTitle(tr("Pick pairs: '%1' to '%2'").arg(s, r));
  instruction_->setText(tr("%1 in '%2' · %3 in '%4'<br>%5")
                            .arg(Swatch(PairPicking::kSourceColor), s.toHtmlEscaped(),
                                 Swatch(PairPicking::kTargetColor), r.toHtmlEscaped(),
                                 picking_->instruction().toHtmlEscaped()));
  list_->setHeaderLabels({tr("#"), tr("in %1 (m)").arg(s), tr("in %1 (m)").arg(r)});
  list_->clear();
  const auto& picks = picking_->picks();
  for (size_t k = 0; k < picks.size(); ++k) {
    auto* item = new QTreeWidgetItem(list_);
    item->setText(0, QString::number(k + 1));
    item->setText(1, Xyz(picks[k].source));
    item->setText(2, picks[k].has_target ? Xyz(picks[k].target) : tr("(pick it in %1)").arg(r));
  }
  if (!picks.empty()) list_->scrollToItem(list_->topLevelItem(list_->topLevelItemCount() - 1));
  const bool idle = !picking_->aligning();
  undo_->setEnabled(idle && picking_->undo_stack()->canUndo());
  align_->setEnabled(picking_->can_align());
  hold_free_->setEnabled(idle);
}

}  // namespace sweepscan::ui
