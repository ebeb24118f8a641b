#include "progress.h"

#include "cli_conventions.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string_view>

namespace blobvk::app {

namespace {
// A bar redrawn in place (carriage return, erase to the end of the line) where stderr is a
// terminal that has those; TERM=dumb (Emacs shells, CI runners that allocate a pseudo-terminal
// but keep a log) gets the plain lines a pipe gets.
bool redrawableTerminal() {
  if (isatty(STDERR_FILENO) == 0) return false;
  const char* term = std::getenv("TERM");
  return !(term && std::string_view(term) == "dumb");
}
}  // namespace

Progress::Progress(std::string what, long total)
    : what_(std::move(what)), total_(total), tty_(redrawableTerminal()), quiet_(quiet()) {}

Progress::~Progress() {
  if (barOpen_) std::fprintf(stderr, "\n");
}

void Progress::update(long done, const std::string& note) {
  if (quiet_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  draw(done, note);
}

void Progress::update(long done, long total) {
  if (quiet_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  total_ = total;
  draw(done, {});
}

void Progress::draw(long done, const std::string& note) {
  const int percent = total_ > 0 ? int(100 * done / total_) : 100;
  if (percent < lastPercent_) return;  // reports from several threads may arrive out of order
  if (tty_) {
    // Redraw at most ~20 times a second, and always at the end.
    const auto now = std::chrono::steady_clock::now();
    if (done < total_ && percent == lastPercent_ && now - lastDraw_ < std::chrono::milliseconds(50)) return;
    lastDraw_ = now;
    const int filled = percent / 5;
    std::fprintf(stderr, "\r%s [%-20s] %3d%% %ld/%ld %s\x1b[K", what_.c_str(), std::string(std::size_t(filled), '#').c_str(),
                 percent, done, total_, note.c_str());
    barOpen_ = done < total_;
    if (!barOpen_) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  } else if (percent / 10 != lastPercent_ / 10) {
    std::fprintf(stderr, "%s %d%% (%ld/%ld)%s%s\n", what_.c_str(), percent, done, total_, note.empty() ? "" : " ",
                 note.c_str());
  }
  lastPercent_ = percent;
}

void Progress::note(const std::string& what, const std::string& text) {
  if (quiet()) return;
  std::fprintf(stderr, "%s: %s\n", what.c_str(), text.c_str());
}

std::function<void(std::size_t, std::size_t)> restartingProgress(std::string what) {
  auto current = std::make_shared<std::unique_ptr<Progress>>();
  return [current, what = std::move(what)](std::size_t done, std::size_t total) {
    if (!*current || done <= 1) *current = std::make_unique<Progress>(what, long(total));
    (*current)->update(long(done));
    if (done >= total) current->reset();  // a finished bar ends its line
  };
}

}  // namespace blobvk::app
