// Progress of long jobs on stderr: a bar redrawn in place when stderr is a terminal, a line at
// every 10 % otherwise (logs stay short), nothing under --quiet. update() may be called from
// several threads at once (the MPU polygonizer reports from its TBB workers).
#pragma once

#include <chrono>
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

}  // namespace blobvk::app
