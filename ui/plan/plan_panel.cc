#include "ui/plan/plan_panel.h"

#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QLabel>
#include <QProgressBar>
#include <QPushButton>
#include <QSettings>
#include <QTimer>
#include <QToolButton>
#include <QVBoxLayout>
#include <memory>

#include "core/plan/plan_writers.h"
#include "ui/plan/plan_build.h"
#include "ui/plan/plan_canvas.h"
#include "ui/project/project_controller.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

const QString kHeightKey = QStringLiteral("plan/height_m");
const QString kBandKey = QStringLiteral("plan/band_m");

// What a build needs, taken on the GUI thread: the clouds (shared, not
// copied) and their poses, or the session's points to convert on the job.
struct PlanSource {
  std::vector<PlanInput> inputs;
  std::shared_ptr<const std::vector<CloudPoint>> session;
  QString what;  // "the project floor (a, b)", "the session lab.sweepscan"
};

}  // namespace

PlanPanel::PlanPanel(ProjectController* project, Workspace* workspace,
                     std::function<void(const QString&, const QString&)> show_error, QWidget* parent)
    : QWidget(parent), project_(project), workspace_(workspace), show_error_(std::move(show_error)) {
  setObjectName(QStringLiteral("planPanel"));
  auto* layout = new QVBoxLayout(this);
  auto* row = new QHBoxLayout;
  row->addWidget(new QLabel(tr("Cut at")));
  height_ = new QDoubleSpinBox;
  height_->setObjectName(QStringLiteral("planHeight"));
  height_->setRange(0.05, 10.0);
  height_->setSingleStep(0.05);
  height_->setDecimals(2);
  height_->setSuffix(tr(" m"));
  height_->setToolTip(tr("The horizontal cut's height above the floor (a surveyor's 1 m: above "
                         "tables, below windows' heads)"));
  row->addWidget(height_);
  row->addWidget(new QLabel(tr("±")));
  band_ = new QDoubleSpinBox;
  band_->setObjectName(QStringLiteral("planBand"));
  band_->setRange(0.01, 0.5);
  band_->setSingleStep(0.01);
  band_->setDecimals(2);
  band_->setSuffix(tr(" m"));
  band_->setToolTip(tr("Half the slab's thickness: the points within it are the section"));
  row->addWidget(band_);
  QSettings settings;
  height_->setValue(settings.value(kHeightKey, 1.0).toDouble());
  band_->setValue(settings.value(kBandKey, 0.05).toDouble());
  row->addStretch(1);
  progress_ = new QProgressBar;
  progress_->setTextVisible(true);
  progress_->setMaximumWidth(220);
  progress_->setVisible(false);
  row->addWidget(progress_);
  cancel_ = new QToolButton;
  cancel_->setObjectName(QStringLiteral("planCancel"));
  cancel_->setText(tr("Cancel"));
  cancel_->setVisible(false);
  connect(cancel_, &QToolButton::clicked, this, [this] {
    again_ = false;
    settle_->stop();
    jobs_.Cancel();
  });
  row->addWidget(cancel_);
  auto* update = new QPushButton(tr("Update"));
  update->setObjectName(QStringLiteral("planUpdate"));
  update->setToolTip(tr("Builds the plan again now (a live cloud grows without rebuilding it)"));
  connect(update, &QPushButton::clicked, this, &PlanPanel::Rebuild);
  row->addWidget(update);
  fit_ = new QPushButton(tr("Fit"));
  fit_->setToolTip(tr("The whole plan in the view (or double-click it)"));
  row->addWidget(fit_);
  export_ = new QPushButton(tr("Export…"));
  export_->setObjectName(QStringLiteral("planExport"));
  export_->setToolTip(tr("The plan as SVG (1:50, paper millimetres) or DXF R12 (metres), by the suffix"));
  connect(export_, &QPushButton::clicked, this, &PlanPanel::ExportWithDialog);
  row->addWidget(export_);
  layout->addLayout(row);
  canvas_ = new PlanCanvas;
  connect(fit_, &QPushButton::clicked, canvas_, &PlanCanvas::Fit);
  layout->addWidget(canvas_, 1);
  summary_ = new QLabel;
  summary_->setObjectName(QStringLiteral("planSummary"));
  summary_->setWordWrap(true);
  summary_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(summary_);

  settle_ = new QTimer(this);
  settle_->setSingleShot(true);
  settle_->setInterval(kSettleMs);
  connect(settle_, &QTimer::timeout, this, [this] {
    if (isVisible()) Rebuild();
  });
  auto cut_changed = [this] {
    QSettings s;
    s.setValue(kHeightKey, height_->value());
    s.setValue(kBandKey, band_->value());
    Stale(false);
  };
  connect(height_, qOverload<double>(&QDoubleSpinBox::valueChanged), this, cut_changed);
  connect(band_, qOverload<double>(&QDoubleSpinBox::valueChanged), this, cut_changed);
  // A placement, a visibility, a session added or removed; clouds built.
  connect(project_->document(), &ProjectDocument::opened, this, [this] { Stale(true); });
  connect(project_->document(), &ProjectDocument::changed, this, [this] { Stale(false); });
  connect(project_, &ProjectController::cloudsChanged, this, [this] { Stale(false); });
  // Without a project: the opened session's cloud, once replayed.
  connect(workspace_, &Workspace::sessionChanged, this, [this] {
    if (!project_->document()->is_open()) Stale(true);
  });
  connect(workspace_, &Workspace::replayFinished, this, [this] {
    if (!project_->document()->is_open()) Stale(true);
  });
  connect(&jobs_, &ProjectJobs::progress, this, &PlanPanel::ShowProgress);
  canvas_->ClearPlan(tr("Open a project (File > Open Project…) or a session to draw its floor plan."));
}

PlanPanel::~PlanPanel() { jobs_.Cancel(); }

bool PlanPanel::settle_pending() const { return settle_->isActive() || again_; }

void PlanPanel::Stale(bool fit) {
  stale_ = true;
  fit_next_ = fit_next_ || fit;
  if (isVisible()) settle_->start();  // Restarted by each edit: one build after a burst.
}

void PlanPanel::showEvent(QShowEvent* event) {
  QWidget::showEvent(event);
  if (stale_ && !jobs_.running()) settle_->start();
}

void PlanPanel::ShowProgress(const QString& what, double fraction) {
  progress_->setVisible(true);
  cancel_->setVisible(true);
  progress_->setFormat(what);
  progress_->setRange(0, fraction < 0 ? 0 : 1000);
  if (fraction >= 0) progress_->setValue(static_cast<int>(1000 * fraction));
}

void PlanPanel::Rebuild() {
  settle_->stop();
  if (jobs_.running()) {
    // The inputs changed under it: its plan is stale, the next starts when it ends.
    again_ = true;
    jobs_.Cancel();
    return;
  }
  again_ = false;
  stale_ = false;
  auto source = std::make_shared<PlanSource>();
  const ProjectDocument* doc = project_->document();
  if (doc->is_open()) {
    QStringList ids;
    bool waiting = false;
    for (const ProjectSession& s : doc->project().sessions) {
      if (!s.project_from_session || !s.visible) continue;
      const auto c = project_->clouds().find(s.id);
      if (c == project_->clouds().end() || c->second->key != CloudKey(doc->path().toStdString(), s)) {
        waiting = true;  // Its cloud is on its way (cloudsChanged rebuilds).
        continue;
      }
      // The cloud's positions, shared with the project (aliasing: no copy).
      source->inputs.push_back(
          {std::shared_ptr<const std::vector<Eigen::Vector3f>>(c->second, &c->second->positions),
           *s.project_from_session});
      ids << QString::fromStdString(s.id);
    }
    if (source->inputs.empty()) {
      canvas_->ClearPlan(waiting ? tr("Waiting for the project's clouds…")
                                 : tr("The project has no placed, visible session to draw."));
      summary_->clear();
      return;
    }
    source->what = tr("project %1 (%2)").arg(QString::fromStdString(doc->project().name), ids.join(", "));
  } else if (workspace_->point_count() > 0) {
    // A copy on the processing thread (the GUI waits for its current batch).
    source->session = std::make_shared<const std::vector<CloudPoint>>(workspace_->CloudSnapshot());
    const QString dir = workspace_->session_dir();
    source->what = dir.isEmpty() ? tr("the live cloud") : tr("session %1").arg(QFileInfo(dir).fileName());
  } else {
    canvas_->ClearPlan(tr("Open a project (File > Open Project…) or a session to draw its floor plan."));
    summary_->clear();
    return;
  }
  plan::FloorPlanOptions options;
  options.section.height_m = height_->value();
  options.section.band_m = band_->value();
  auto plan = std::make_shared<plan::FloorPlan>();
  const QString what = tr("Floor plan at %1 m").arg(options.section.height_m, 0, 'f', 2);
  const bool fit = fit_next_;
  fit_next_ = false;
  jobs_.Run(
      what,
      [source, options, plan, what](std::atomic<bool>* cancel, const ProjectJobs::Progress& progress) {
        std::vector<PlanInput> inputs = source->inputs;
        if (source->session) {
          auto xyz = std::make_shared<std::vector<Eigen::Vector3f>>();
          xyz->reserve(source->session->size());
          for (const CloudPoint& p : *source->session) xyz->emplace_back(p.x, p.y, p.z);
          inputs.push_back({xyz, Rigid3d()});
        }
        const Status s = BuildPlanOf(inputs, options, [&](double f) {
          progress(f < 0.6 ? what + tr(": cutting") : what + tr(": fitting walls"), f);
          return !*cancel;
        }, plan.get());
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, source, plan, fit, options](const QString& error) {
        progress_->setVisible(false);
        cancel_->setVisible(false);
        if (again_) {
          Rebuild();
          return;
        }
        if (error == QLatin1String(kPlanCancelled) || jobs_.cancelled()) {
          stale_ = true;  // Built again when next asked for.
          summary_->setText(tr("Cancelled: the plan shown is the last one built (Update with a new cut)."));
          emit planBuilt(false, tr("cancelled"));
          return;
        }
        if (!error.isEmpty()) {
          canvas_->ClearPlan(tr("No plan: %1").arg(error));
          summary_->setText(tr("No plan of %1: %2").arg(source->what, error));
          emit planBuilt(false, error);
          return;
        }
        ++plans_built_;
        canvas_->SetPlan(*plan, fit);
        size_t structural = 0;
        for (const plan::WallFace& f : plan->faces) structural += f.structural ? 1 : 0;
        title_ = tr("sweepscan plan of %1: section at %2 m ± %3 m")
                     .arg(source->what)
                     .arg(options.section.height_m, 0, 'f', 2)
                     .arg(options.section.band_m, 0, 'f', 2);
        const QString text = tr("%1 · section %L2 of %L3 points · %4 wall faces (%5 furniture), %6 walls, "
                                "%7 openings, %8 dimensions")
                                 .arg(source->what)
                                 .arg(plan->section.points_out)
                                 .arg(plan->section.points_in)
                                 .arg(structural)
                                 .arg(plan->faces.size() - structural)
                                 .arg(plan->walls.size())
                                 .arg(plan->openings.size())
                                 .arg(plan->dimensions.size());
        summary_->setText(text);
        emit planBuilt(true, text);
      });
}

bool PlanPanel::ExportPlan(const QString& path, QString* error) const {
  if (!canvas_->plan()) {
    *error = tr("There is no floor plan to export yet: View > Floor Plan draws one.");
    return false;
  }
  const QString suffix = QFileInfo(path).suffix().toLower();
  Status s;
  if (suffix == QLatin1String("svg")) {
    plan::SvgOptions o;
    o.title = title_.toStdString();
    s = plan::WritePlanSvg(path.toStdString(), *canvas_->plan(), o);
  } else if (suffix == QLatin1String("dxf")) {
    s = plan::WritePlanDxf(path.toStdString(), *canvas_->plan(), plan::DxfOptions());
  } else {
    *error = tr("%1: the suffix says the format: .svg or .dxf").arg(path);
    return false;
  }
  if (!s.ok()) *error = QString::fromStdString(s.message());
  return s.ok();
}

void PlanPanel::ExportWithDialog() {
  if (!canvas_->plan()) {
    show_error_(tr("Cannot export the floor plan"),
                tr("There is no floor plan to export yet: View > Floor Plan draws one."));
    return;
  }
  const QString svg = tr("SVG drawing, 1:50 (*.svg)"), dxf = tr("DXF R12 drawing, metres (*.dxf)");
  QString filter;
  QString path = QFileDialog::getSaveFileName(this, tr("Export floor plan"), QString(),
                                              svg + QStringLiteral(";;") + dxf, &filter);
  if (path.isEmpty()) return;
  const QString suffix = QFileInfo(path).suffix().toLower();
  if (suffix != QLatin1String("svg") && suffix != QLatin1String("dxf")) {
    path += filter == dxf ? QStringLiteral(".dxf") : QStringLiteral(".svg");
  }
  QString error;
  if (!ExportPlan(path, &error)) show_error_(tr("Cannot export the floor plan"), error);
}

}  // namespace sweepscan::ui
