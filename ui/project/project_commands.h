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
#include <functional>

#include "core/project/project.h"
#include "ui/project/project_document.h"

namespace sweepscan::ui {

class ProjectEditCommand : public QUndoCommand {
 public:
  // `move_frame` (a change of anchor): every placement of `after` is
  // new_from_old times its place in the document's project. Called with
  // new_from_old on redo and its inverse on undo, so that what is drawn in
  // the project's frame (the view's camera) moves with it and the building
  // holds still on screen.
  ProjectEditCommand(ProjectDocument* document, Project after, const QString& text,
                     std::function<void(const Rigid3d&)> move_frame = {},
                     const Rigid3d& new_from_old = Rigid3d())
      : document_(document),
        generation_(document->generation()),
        before_(document->project()),
        after_(std::move(after)),
        move_frame_(std::move(move_frame)),
        new_from_old_(new_from_old) {
    setText(text);
  }
  void redo() override {
    if (Apply(after_) && move_frame_) move_frame_(new_from_old_);
  }
  void undo() override {
    if (Apply(before_) && move_frame_) move_frame_(new_from_old_.inverse());
  }

 private:
  bool Apply(const Project& p) {
    if (document_->generation() != generation_) {
      setObsolete(true);
      return false;
    }
    document_->Set(p);
    return true;
  }

  ProjectDocument* document_;
  uint64_t generation_;
  Project before_, after_;
  std::function<void(const Rigid3d&)> move_frame_;
  Rigid3d new_from_old_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PROJECT_PROJECT_COMMANDS_H_
