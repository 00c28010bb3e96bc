// Undoable project edits (visibility, colour, adding and removing a
// session, a placement by alignment, a change of anchor) on the project's QUndoStack: each
// holds the project before and after, which are small (no points). The
// stack is cleared whenever the document's generation changes; should a
// command of an older generation still be reached, it becomes obsolete
// instead of editing the project open now.
//
// GUI thread only.
#ifndef SWEEPSCAN_UI_PROJECT_PROJECT_COMMANDS_H_
#define SWEEPSCAN_UI_PROJECT_PROJECT_COMMANDS_H_

#include <QString>
#include <QUndoCommand>
#include <cstdint>

#include "core/project/project.h"
#include "ui/project/project_document.h"

namespace sweepscan::ui {

class ProjectEditCommand : public QUndoCommand {
 public:
  ProjectEditCommand(ProjectDocument* document, Project after, const QString& text)
      : document_(document),
        generation_(document->generation()),
        before_(document->project()),
        after_(std::move(after)) {
    setText(text);
  }
  void redo() override { Apply(after_); }
  void undo() override { Apply(before_); }

 private:
  void Apply(const Project& p) {
    if (document_->generation() != generation_) {
      setObsolete(true);
      return;
    }
    document_->Set(p);
  }

  ProjectDocument* document_;
  uint64_t generation_;
  Project before_, after_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PROJECT_COMMANDS_H_
