#include "ui/undo_router.h"

#include <QUndoStack>
#include <algorithm>

namespace sweepscan::ui {

UndoRouter::UndoRouter(QObject* parent) : QObject(parent) {}

void UndoRouter::AddStack(QUndoStack* stack) {
  group_.addStack(stack);
  recency_.push_back(stack);
  if (fallback_ == nullptr) {
    fallback_ = stack;
    group_.setActiveStack(stack);
  }
  connect(stack, &QUndoStack::indexChanged, this, [this, stack] { OnIndexChanged(stack); });
  connect(stack, &QObject::destroyed, this, [this, stack] {
    recency_.erase(std::remove(recency_.begin(), recency_.end(), stack), recency_.end());
    if (fallback_ == stack) fallback_ = nullptr;
  });
}

void UndoRouter::Activate(QUndoStack* stack) {
  Touch(stack);
  group_.setActiveStack(stack);
}

void UndoRouter::Push(QUndoCommand* command) {
  QUndoStack* stack = group_.activeStack() != nullptr ? group_.activeStack() : fallback_;
  if (stack == nullptr) {
    delete command;
    return;
  }
  stack->push(command);  // indexChanged activates it.
}

// QUndoStack says indexChanged for a push, an undo, a redo and a clear; a
// cleared stack is the only one left with no commands.
void UndoRouter::OnIndexChanged(QUndoStack* stack) {
  if (stack->count() > 0) {
    Activate(stack);
    return;
  }
  Leave(stack);
}

void UndoRouter::Leave(QUndoStack* stack) {
  if (group_.activeStack() != stack) return;
  QUndoStack* next = nullptr;
  for (QUndoStack* other : recency_) {
    if (other == stack) continue;
    if (other->count() > 0) {
      next = other;
      break;
    }
    if (next == nullptr) next = other;  // none holds commands: the most recent
  }
  if (next != nullptr) Activate(next);
}

void UndoRouter::Touch(QUndoStack* stack) {
  auto it = std::find(recency_.begin(), recency_.end(), stack);
  if (it != recency_.end()) recency_.erase(it);
  recency_.insert(recency_.begin(), stack);
}

}  // namespace sweepscan::ui
