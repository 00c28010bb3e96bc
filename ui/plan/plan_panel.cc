#include "ui/plan/plan_panel.h"

#include <QAction>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFileInfo>
#include <QHBoxLayout>
#include <QLabel>
#include <QProgressBar>
#include <QPushButton>
#include <QSettings>
#include <QSplitter>
#include <QStringList>
#include <QTimer>
#include <QToolButton>
#include <QVBoxLayout>
#include <cmath>
#include <limits>
#include <memory>

#include "core/plan/plan_writers.h"
#include "core/plan/rooms.h"
#include "ui/plan/plan_build.h"
#include "ui/plan/plan_canvas.h"
#include "ui/plan/section_canvas.h"
#include "ui/project/project_controller.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

const QString kHeightKey = QStringLiteral("plan/height_m");
const QString kBandKey = QStringLiteral("plan/band_m");
const QString kSectionKey = QStringLiteral("plan/section_line");  // x0, y0, x1, y1 (m)

// What a build needs, taken on the GUI thread: the clouds (shared, not
// copied) and their poses, or the session's points to convert on the job.
struct PlanSource {
  std::vector<PlanInput> inputs;
  std::shared_ptr<const CloudSnapshotRef> session;  // decoded on the job
  QString what;  // "the project floor (a, b)", "the session lab.sweepscan"
};

// The project's placed, visible sessions whose clouds are built, or the
// session's cloud; null with why not in `*why_not`.
std::shared_ptr<PlanSource> TakeSource(ProjectController* project, Workspace* workspace, QString* why_not) {
  auto source = std::make_shared<PlanSource>();
  const ProjectDocument* doc = project->document();
  if (doc->is_open()) {
    QStringList ids;
    bool waiting = false;
    for (const ProjectSession& s : doc->project().sessions) {
      if (!s.project_from_session || !s.visible) continue;
      const auto c = project->clouds().find(s.id);
      if (c == project->clouds().end() || c->second->key != CloudKey(doc->path().toStdString(), s)) {
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
      *why_not = waiting ? PlanPanel::tr("Waiting for the project's clouds…")
                         : PlanPanel::tr("The project has no placed, visible session to draw.");
      return nullptr;
    }
    source->what =
        PlanPanel::tr("project %1 (%2)").arg(QString::fromStdString(doc->project().name), ids.join(", "));
  } else if (workspace->point_count() > 0) {
    // The chunks as they are now (cheap); decoded on the job.
    source->session = std::make_shared<const CloudSnapshotRef>(workspace->CloudSnapshot());
    const QString dir = workspace->session_dir();
    source->what =
        dir.isEmpty() ? PlanPanel::tr("the live cloud") : PlanPanel::tr("session %1").arg(QFileInfo(dir).fileName());
  } else {
    *why_not = PlanPanel::tr("Open a project (File > Open Project…) or a session to draw its floor plan.");
    return nullptr;
  }
  return source;
}

// On the job thread: the inputs, the session's points converted.
std::vector<PlanInput> InputsOf(const PlanSource& source) {
  std::vector<PlanInput> inputs = source.inputs;
  if (source.session) {
    auto xyz = std::make_shared<std::vector<Eigen::Vector3f>>();
    xyz->reserve(source.session->size());
    source.session->ForEachChunk([&](const CloudPoint* p, size_t n) {  // not decoded whole
      for (size_t i = 0; i < n; ++i) xyz->emplace_back(p[i].x, p[i].y, p[i].z);
      return true;
    });
    inputs.push_back({xyz, Rigid3d()});
  }
  return inputs;
}

// What a job builds: the plan, the section, or both.
struct Built {
  plan::FloorPlan plan;
  double level_near_cut =
      std::numeric_limits<double>::quiet_NaN();  // a floor or ceiling in the cut
  bool section_wanted = false;
  SectionOf section;
  QString section_error;  // "" when built
};

// The section of `inputs` into `built`; false when cancelled.
bool BuildSection(const std::vector<PlanInput>& inputs, const plan::VerticalSectionOptions& options,
                  std::atomic<bool>* cancel, const ProjectJobs::Progress& progress, Built* built) {
  const QString what = PlanPanel::tr("Section A–A′");
  const Status s = BuildSectionOf(inputs, options, [&](double f) {
    progress(what, f);
    return !*cancel;
  }, &built->section);
  built->section_wanted = true;
  built->section_error = s.ok() ? QString() : QString::fromStdString(s.message());
  return !*cancel;
}

// A push button at the end of `row`.
QPushButton* AddButton(QHBoxLayout* row, const QString& text, const QString& name, const QString& tip) {
  auto* b = new QPushButton(text);
  if (!name.isEmpty()) b->setObjectName(name);
  b->setToolTip(tip);
  row->addWidget(b);
  return b;
}

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
  layout->addLayout(row);
  // The buttons on a second row: on one with the cut's boxes the panel
  // could not be narrower than about 730 px, and a plan docked beside the
  // panels squeezed the 3D view to a strip.
  row = new QHBoxLayout;
  QPushButton* update = AddButton(row, tr("Update"), QStringLiteral("planUpdate"),
                                  tr("Builds the plan again now (a live cloud grows without rebuilding it)"));
  connect(update, &QPushButton::clicked, this, &PlanPanel::Rebuild);
  fit_ = AddButton(row, tr("Fit"), QString(), tr("The whole plan in the view (or double-click it)"));
  export_ = AddButton(row, tr("Export…"), QStringLiteral("planExport"),
                      tr("The plan as SVG (1:50, paper millimetres) or DXF R12 (metres), by the suffix"));
  connect(export_, &QPushButton::clicked, this, &PlanPanel::ExportWithDialog);
  section_tool_ = new QToolButton;
  section_tool_->setObjectName(QStringLiteral("planSectionTool"));
  section_tool_->setText(tr("Section"));
  section_tool_->setCheckable(true);
  // No letter key: W A S D drive the robot (MainWindow's key filter).
  section_tool_->setToolTip(tr("Draw a vertical section: drag its line A → A′ on the plan (or Shift + drag "
                               "without the button; Esc cancels). The section looks the way the arrows point."));
  row->addWidget(section_tool_);
  row->addStretch(1);
  layout->addLayout(row);
  canvas_ = new PlanCanvas;
  connect(fit_, &QPushButton::clicked, canvas_, &PlanCanvas::Fit);
  connect(section_tool_, &QToolButton::toggled, canvas_, &PlanCanvas::SetSectionMode);
  connect(canvas_, &PlanCanvas::sectionModeChanged, section_tool_, &QToolButton::setChecked);
  connect(canvas_, &PlanCanvas::sectionLineDrawn, this, [this] { SetSectionLine(canvas_->section_line()); });
  splitter_ = new QSplitter(Qt::Vertical);
  splitter_->setObjectName(QStringLiteral("planSplitter"));
  splitter_->setChildrenCollapsible(false);
  splitter_->addWidget(canvas_);
  splitter_->addWidget(MakeSectionPane());
  splitter_->setStretchFactor(0, 3);
  splitter_->setStretchFactor(1, 2);
  layout->addWidget(splitter_, 1);
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
  connect(canvas_, &PlanCanvas::contentChanged, this, &PlanPanel::UpdateActions);
  canvas_->ClearPlan(tr("Open a project (File > Open Project…) or a session to draw its floor plan."));
  // The last section line, drawn again over the next plan.
  const QVariantList line = settings.value(kSectionKey).toList();
  if (line.size() == 4) {
    SectionLine l;
    l.a = {line[0].toDouble(), line[1].toDouble()};
    l.b = {line[2].toDouble(), line[3].toDouble()};
    if (l.a.allFinite() && l.b.allFinite() && (l.b - l.a).norm() >= 1e-3) {
      canvas_->SetSectionLine(l);
      ++line_serial_;
      section_pane_->setVisible(true);
    }
  }
  UpdateActions();
}

QWidget* PlanPanel::MakeSectionPane() {
  section_pane_ = new QWidget;
  section_pane_->setObjectName(QStringLiteral("planSectionPane"));
  auto* layout = new QVBoxLayout(section_pane_);
  layout->setContentsMargins(0, 0, 0, 0);
  auto* row = new QHBoxLayout;
  section_summary_ = new QLabel;
  section_summary_->setObjectName(QStringLiteral("planSectionSummary"));
  section_summary_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  row->addWidget(section_summary_, 1);
  section_fit_ = AddButton(row, tr("Fit"), QString(),
                           tr("The whole section in the view (or double-click it)"));
  section_export_ = AddButton(row, tr("Export Section…"), QStringLiteral("planSectionExport"),
                              tr("The section as SVG (1:50, paper millimetres, z up)"));
  connect(section_export_, &QPushButton::clicked, this, &PlanPanel::ExportSectionWithDialog);
  section_remove_ = new QToolButton;
  section_remove_->setObjectName(QStringLiteral("planSectionClear"));
  section_remove_->setText(tr("Remove"));
  connect(section_remove_, &QToolButton::clicked, this, [this] { SetSectionLine(std::nullopt); });
  row->addWidget(section_remove_);
  layout->addLayout(row);
  section_canvas_ = new SectionCanvas;
  connect(section_fit_, &QPushButton::clicked, section_canvas_, &SectionCanvas::Fit);
  connect(section_canvas_, &SectionCanvas::contentChanged, this, &PlanPanel::UpdateActions);
  layout->addWidget(section_canvas_, 1);
  section_pane_->setVisible(false);
  return section_pane_;
}

PlanPanel::~PlanPanel() { jobs_.Cancel(); }

bool PlanPanel::settle_pending() const { return settle_->isActive() || again_; }

void PlanPanel::Stale(bool fit) {
  stale_ = true;
  fit_next_ = fit_next_ || fit;
  if (isVisible()) settle_->start();  // Restarted by each edit: one build after a burst.
  UpdateActions();  // A project or session opened or closed: File > Export Floor Plan.
}

void PlanPanel::showEvent(QShowEvent* event) {
  QWidget::showEvent(event);
  if (stale_ && !jobs_.running()) settle_->start();
  UpdateActions();
}

void PlanPanel::hideEvent(QHideEvent* event) {
  QWidget::hideEvent(event);
  UpdateActions();
}

void PlanPanel::SetFileExportAction(QAction* action) {
  file_export_ = action;
  UpdateActions();
}

void PlanPanel::UpdateActions() {
  // Enabled only when they can act, the reason in the tooltip when not
  // (Export… once said "View > Floor Plan draws one" with the dock open
  // and a cut height that found no walls).
  const bool plan = canvas_->plan().has_value();
  const QString why = canvas_->empty_text();
  export_->setEnabled(plan);
  export_->setToolTip(
      plan ? tr("The plan as SVG (1:50, paper millimetres) or DXF R12 (metres), by the suffix")
           : tr("No plan to export: %1").arg(why));
  if (file_export_ != nullptr) {
    // Hidden, the dock builds no plan: the action says how to get one.
    const bool source = project_->document()->is_open() || workspace_->point_count() > 0;
    file_export_->setEnabled(plan || (source && !isVisible()));
    file_export_->setToolTip(plan || (source && !isVisible()) ? QString()
                             : source                         ? tr("No plan to export: %1").arg(why)
                                      : tr("Open a project or a session first"));
  }
  const std::optional<SectionOf>& section = section_canvas_->section();
  const bool has_section = section && !section->s_z.empty();
  section_export_->setEnabled(has_section);
  section_fit_->setEnabled(has_section);
  section_export_->setToolTip(has_section
                                  ? tr("The section as SVG (1:50, paper millimetres, z up) or DXF")
                                  : tr("No section to export yet"));
  const bool line = canvas_->section_line().has_value() && plan;
  section_remove_->setEnabled(line);
  section_remove_->setToolTip(line ? tr("Removes the section line and its section")
                                   : tr("No section line on a plan to remove"));
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
  QString why_not;
  const std::shared_ptr<PlanSource> source = TakeSource(project_, workspace_, &why_not);
  if (!source) {
    canvas_->ClearPlan(why_not);
    section_canvas_->ClearSection(why_not);
    summary_->clear();
    section_summary_->clear();
    return;
  }
  plan::FloorPlanOptions options;
  options.section.height_m = height_->value();
  options.section.band_m = band_->value();
  std::optional<plan::VerticalSectionOptions> vertical;
  if (canvas_->section_line()) {
    vertical.emplace();
    vertical->a = canvas_->section_line()->a;
    vertical->b = canvas_->section_line()->b;
    vertical->band_m = options.section.band_m;
  }
  auto built = std::make_shared<Built>();
  const QString what = tr("Floor plan at %1 m").arg(options.section.height_m, 0, 'f', 2);
  const bool fit = fit_next_;
  const uint64_t serial = line_serial_;
  fit_next_ = false;
  jobs_.Run(
      what,
      [source, options, vertical, built, what](std::atomic<bool>* cancel, const ProjectJobs::Progress& progress) {
        const std::vector<PlanInput> inputs = InputsOf(*source);
        const Status s = BuildPlanOf(
            inputs, options,
            [&](double f) {
              progress(f < 0.6 ? what + tr(": cutting") : what + tr(": fitting walls"), f);
              return !*cancel;
            },
            &built->plan, &built->level_near_cut);
        if (*cancel) return QString(kPlanCancelled);
        // The section too, whether the plan's cut found walls or not.
        if (vertical && !BuildSection(inputs, *vertical, cancel, progress, built.get())) {
          return QString(kPlanCancelled);
        }
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, source, built, fit, options, serial](const QString& error) {
        if (!JobEnded()) return;
        if (error == QLatin1String(kPlanCancelled) || jobs_.cancelled()) {
          stale_ = true;  // Built again when next asked for.
          summary_->setText(tr("Cancelled: the plan shown is the last one built (Update with a new cut)."));
          emit planBuilt(false, tr("cancelled"));
          return;
        }
        what_ = source->what;
        if (built->section_wanted && serial == line_serial_) {
          section_shown_serial_ = serial;
          ShowSection(built->section, false);
          if (!built->section_error.isEmpty()) {
            section_canvas_->ClearSection(tr("No section: %1").arg(built->section_error));
          }
        }
        if (serial != line_serial_) RebuildSection();  // A line drawn meanwhile.
        if (!error.isEmpty()) {
          canvas_->ClearPlan(tr("No plan: %1").arg(error));
          summary_->setText(tr("No plan of %1: %2").arg(source->what, error));
          emit planBuilt(false, error);
          return;
        }
        ++plans_built_;
        const plan::FloorPlan& plan = built->plan;
        canvas_->SetPlan(plan, fit);
        size_t structural = 0;
        for (const plan::WallFace& f : plan.faces) structural += f.structural ? 1 : 0;
        title_ = tr("sweepscan plan of %1: section at %2 m ± %3 m")
                     .arg(source->what)
                     .arg(options.section.height_m, 0, 'f', 2)
                     .arg(options.section.band_m, 0, 'f', 2);
        // The CLI's words (`plan`): faces of walls and of furniture, and
        // walls seen from both sides (two faces back to back, thickness known).
        const QString text =
            tr("%1 · section %L2 of %L3 points · %4 faces (%5 of walls, %6 of furniture), "
               "%7 walls seen from both sides, %8 openings, %9 dimensions, %10 rooms")
                .arg(source->what)
                .arg(plan.section.points_out)
                .arg(plan.section.points_in)
                .arg(plan.faces.size())
                .arg(structural)
                .arg(plan.faces.size() - structural)
                .arg(plan.walls.size())
                .arg(plan.openings.size())
                .arg(plan.dimensions.size())
                .arg(plan.rooms.size());
        // What the CLI warns about, said where the operator looks.
        QStringList notes;
        if (std::isfinite(built->level_near_cut)) {
          notes << tr("The cut is within 3 cm of a level surface at %1 m (a floor or a ceiling): "
                      "its points "
                      "are drawn as walls; cut at least 0.1 m from it.")
                       .arg(built->level_near_cut, 0, 'f', 2);
        }
        if (const std::string why = plan::NoRoomsReason(plan); !why.empty()) {
          QString line = QString::fromStdString(why);
          line[0] = line[0].toUpper();
          notes << line + QLatin1Char('.');
        }
        summary_->setText(
            notes.isEmpty() ? text : text + QLatin1Char('\n') + notes.join(QLatin1Char(' ')));
        emit planBuilt(true, text);
      });
}

bool PlanPanel::JobEnded() {
  progress_->setVisible(false);
  cancel_->setVisible(false);
  if (!again_) return true;
  Rebuild();
  return false;
}

void PlanPanel::SetSectionLine(const std::optional<SectionLine>& line) {
  canvas_->SetSectionLine(line);
  ++line_serial_;
  QSettings settings;
  if (!line) {
    settings.remove(kSectionKey);
    section_canvas_->ClearSection(tr("No section"));
    section_shown_serial_ = 0;
    section_summary_->clear();
    section_pane_->setVisible(false);
    return;
  }
  settings.setValue(kSectionKey, QVariantList{line->a.x(), line->a.y(), line->b.x(), line->b.y()});
  section_pane_->setVisible(true);
  UpdateActions();
  RebuildSection();
}

void PlanPanel::RebuildSection() {
  // A build under way ends with the section of the line it started with;
  // its end starts this one's if the line changed (or it was cancelled).
  if (jobs_.running() || !canvas_->section_line()) return;
  if (!isVisible()) {
    stale_ = true;  // Built with the plan when the dock is next shown.
    return;
  }
  QString why_not;
  const std::shared_ptr<PlanSource> source = TakeSource(project_, workspace_, &why_not);
  if (!source) {
    section_canvas_->ClearSection(why_not);
    return;
  }
  plan::VerticalSectionOptions options;
  options.a = canvas_->section_line()->a;
  options.b = canvas_->section_line()->b;
  options.band_m = band_->value();
  auto built = std::make_shared<Built>();
  const uint64_t serial = line_serial_;
  jobs_.Run(
      tr("Section A–A′"),
      [source, options, built](std::atomic<bool>* cancel, const ProjectJobs::Progress& progress) {
        return BuildSection(InputsOf(*source), options, cancel, progress, built.get()) ? QString()
                                                                                       : QString(kPlanCancelled);
      },
      [this, source, built, serial](const QString& error) {
        if (!JobEnded()) return;
        if (!error.isEmpty() || jobs_.cancelled()) return;  // The section shown stays.
        what_ = source->what;
        if (serial != line_serial_) {
          RebuildSection();  // Another line drawn meanwhile.
          return;
        }
        const bool new_line = section_shown_serial_ != serial;
        section_shown_serial_ = serial;
        if (!built->section_error.isEmpty()) {
          section_canvas_->ClearSection(tr("No section: %1").arg(built->section_error));
          section_summary_->setText(tr("No section: %1").arg(built->section_error));
          return;
        }
        ShowSection(built->section, new_line);
      });
}

void PlanPanel::ShowSection(const SectionOf& section, bool fit) {
  ++sections_built_;
  section_canvas_->SetSection(section, height_->value(), fit);
  const plan::VerticalSectionOptions& o = section.options;
  section_summary_->setText(tr("Section A–A′ %1 m ± %2 m · %L3 points")
                                .arg((o.b - o.a).norm(), 0, 'f', 2)
                                .arg(o.band_m, 0, 'f', 2)
                                .arg(section.stats.points_out));
  section_summary_->setToolTip(tr("A (%1, %2) → A′ (%3, %4) in the plan's frame (m); seen from the side the "
                                  "arrows on the plan point away from")
                                   .arg(o.a.x(), 0, 'f', 2)
                                   .arg(o.a.y(), 0, 'f', 2)
                                   .arg(o.b.x(), 0, 'f', 2)
                                   .arg(o.b.y(), 0, 'f', 2));
}

QString PlanPanel::NoPlanReason() const {
  // Hidden, the dock builds nothing; shown, the canvas says why it has no plan.
  if (!isVisible() || canvas_->empty_text().isEmpty()) {
    return tr("There is no floor plan to export yet: View > Floor Plan draws one.");
  }
  return tr("There is no floor plan to export: %1").arg(canvas_->empty_text());
}

bool PlanPanel::ExportPlan(const QString& path, QString* error) const {
  if (!canvas_->plan()) {
    *error = NoPlanReason();
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
    show_error_(tr("Cannot export the floor plan"), NoPlanReason());
    return;
  }
  const QString svg = tr("SVG drawing, 1:50 (*.svg)"), dxf = tr("DXF R12 drawing, metres (*.dxf)");
  QString filter;
  // Beside the project (or the session) it was drawn from, named after it.
  const QString from = !project_->document()->path().isEmpty() ? project_->document()->path()
                                                               : workspace_->session_dir();
  const QFileInfo source(from);
  const QString start = from.isEmpty()
                            ? QString()
                            : source.absolutePath() + QLatin1Char('/') + source.completeBaseName() +
                                  QStringLiteral("-plan.svg");
  QString path = QFileDialog::getSaveFileName(this, tr("Export floor plan"), start,
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

namespace sweepscan::ui {

bool PlanPanel::ExportSection(const QString& path, QString* error) const {
  const std::optional<SectionOf>& section = section_canvas_->section();
  if (!section || section->s_z.empty()) {
    *error = tr("There is no section to export yet: drag its line on the floor plan (Section, or Shift + drag).");
    return false;
  }
  const QString suffix = QFileInfo(path).suffix().toLower();
  if (suffix != QLatin1String("svg") && suffix != QLatin1String("dxf")) {
    *error = tr("%1: a section is written as SVG (.svg) or DXF (.dxf)").arg(path);
    return false;
  }
  const plan::VerticalSectionOptions& o = section->options;
  plan::SvgOptions svg;
  svg.title = tr("sweepscan vertical section A-A' of %1: (%2, %3) -> (%4, %5) m +- %6 m; s, z in m")
                  .arg(what_)
                  .arg(o.a.x(), 0, 'f', 2)
                  .arg(o.a.y(), 0, 'f', 2)
                  .arg(o.b.x(), 0, 'f', 2)
                  .arg(o.b.y(), 0, 'f', 2)
                  .arg(o.band_m, 0, 'f', 2)
                  .toStdString();
  const Status s = suffix == QLatin1String("dxf")
                       ? plan::WriteSectionDxf(path.toStdString(), section->s_z, plan::DxfOptions())
                       : plan::WriteSectionSvg(path.toStdString(), section->s_z, svg);
  if (!s.ok()) *error = QString::fromStdString(s.message());
  return s.ok();
}

void PlanPanel::ExportSectionWithDialog() {
  QString error;
  if (!section_canvas_->section()) {
    ExportSection(QString(), &error);
    show_error_(tr("Cannot export the section"), error);
    return;
  }
  QString filter;
  QString path = QFileDialog::getSaveFileName(this, tr("Export section"), QString(),
                                              tr("SVG drawing, 1:50 (*.svg);;DXF R12, metres (*.dxf)"), &filter);
  if (path.isEmpty()) return;
  const QString suffix = QFileInfo(path).suffix().toLower();
  if (suffix != QLatin1String("svg") && suffix != QLatin1String("dxf")) {
    path += filter.contains(QLatin1String("dxf")) ? QStringLiteral(".dxf") : QStringLiteral(".svg");
  }
  if (!ExportSection(path, &error)) show_error_(tr("Cannot export the section"), error);
}

}  // namespace sweepscan::ui
