// A progress line on stderr for long jobs: redrawn in place on a terminal, a line every 10 %
// otherwise (logs stay readable).
#pragma once

#include <cstdio>
#include <string>
#include <unistd.h>

namespace blobvk::app {

class Progress {
 public:
  Progress(std::string what, long total) : what_(std::move(what)), total_(total), tty_(isatty(2)) {}

  void update(long done, const std::string& note = {}) {
    const int percent = total_ > 0 ? int(100 * done / total_) : 100;
    if (tty_) {
      const int filled = percent / 5;
      std::fprintf(stderr, "\r%s [%-20s] %ld/%ld %s", what_.c_str(), std::string(std::size_t(filled), '#').c_str(),
                   done, total_, note.c_str());
      if (done >= total_) std::fprintf(stderr, "\n");
      std::fflush(stderr);
    } else if (percent / 10 != last_ / 10 || done >= total_) {
      std::fprintf(stderr, "%s %d%% (%ld/%ld) %s\n", what_.c_str(), percent, done, total_, note.c_str());
    }
    last_ = percent;
  }

 private:
  std::string what_;
  long total_;
  bool tty_;
  int last_ = -1;
};

}  // namespace blobvk::app
