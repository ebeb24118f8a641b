// Progress of long jobs on stderr: a bar redrawn in place when stderr is a terminal, a line at
// every 10 % otherwise (logs stay short), nothing under --quiet. update() may be called from
// several threads at once (the MPU polygonizer reports from its TBB workers).
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>

namespace blobvk::app {

class Progress {
 public:
  Progress(std::string what, long total);
  ~Progress();  // ends a terminal bar's line
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void update(long done, const std::string& note = {});
  // The same, when the total is only known once the work runs (the MPU count).
  void update(long done, long total);

  // One informational line "WHAT: TEXT" on stderr (a phase without a count), unless quiet.
  static void note(const std::string& what, const std::string& text);

 private:
  std::mutex mutex_;
  std::string what_;
  long total_;
  bool tty_, quiet_;
  int lastPercent_ = -1;
  bool barOpen_ = false;
  std::chrono::steady_clock::time_point lastDraw_{};
  void draw(long done, const std::string& note);  // mutex_ held
};

// A (done, total) callback drawing a Progress named `what`, begun afresh whenever `done` starts
// again from 1 (a phase run again, as the classification is with smaller bricks).
std::function<void(std::size_t done, std::size_t total)> restartingProgress(std::string what);

}  // namespace blobvk::app
