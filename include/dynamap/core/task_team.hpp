// TaskTeam: threads that run one task together, for a frame's data parallelism. The pipeline
// owns the team (platform::WorkerTeam) and lends it to a stage for one call; stages never start
// threads, so the stage folders need nothing from platform/. A stage's result must not depend on
// how many members the team has or which member runs which part.
#pragma once

namespace dynamap {

/// Most members a team may have, the calling thread included (bounds per-member scratch).
inline constexpr unsigned kMaxTeamMembers = 4;

class TaskTeam {
 public:
  /// task(context, member): member in [0, size()); member 0 is the thread that called run().
  using Task = void (*)(void* context, unsigned member);

  /// Members including the caller of run(), 1..kMaxTeamMembers.
  virtual unsigned size() const noexcept = 0;
  /// Runs task(context, m) on every member m and returns when all have returned. Called from
  /// one thread at a time (the team's owner's); no allocation, lock or thread creation.
  virtual void run(Task task, void* context) noexcept = 0;

 protected:
  TaskTeam() = default;
  TaskTeam(const TaskTeam&) = default;
  TaskTeam& operator=(const TaskTeam&) = default;
  ~TaskTeam() = default;
};

/// The calling thread alone: what a stage uses when no team is lent to it.
class SoloTeam final : public TaskTeam {
 public:
  unsigned size() const noexcept override { return 1; }
  void run(Task task, void* context) noexcept override { task(context, 0); }
};

}  // namespace dynamap
