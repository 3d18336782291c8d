#pragma once
// Progress of a long command (sweep, basin, the experiments, bench) on stderr: on a terminal one
// bar redrawn in place with the count, the rate and the time left; otherwise (a log file, a
// cluster job's output) plain lines, one per finished item; nothing with --quiet.
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>
#include <utility>

namespace ambler::eval {

// "0:07", "12:34", "1:02:03" (h:mm:ss from an hour on); "--:--" for a time not known.
std::string clockText(double seconds);

// The bar's line, at most `width` characters:
//   "sweep [=========>          ] 12/36  33%  0.81/s  ETA 0:29  run 11: seed=2 rms=0.0071 m"
// The rate counts the items finished in this process (done - resumed) over `elapsed_s`; the ETA is
// the items left at that rate. The detail is cut to fit.
std::string progressBar(std::string_view what, std::size_t done, std::size_t total, std::size_t resumed,
                        double elapsed_s, std::string_view detail, std::size_t width);

class Progress {
 public:
  enum class Mode { Off, Lines, Bar };
  // Off unless `enabled`; Bar when stderr is a terminal (and TERM is not "dumb"), Lines otherwise.
  // The environment variable AMBLER_PROGRESS=lines or =bar overrides the choice.
  static Mode modeFor(bool enabled);

  // `already`: items recorded by an earlier attempt (a resume), counted as done but not in the rate.
  // `line_interval`: in Lines mode, at most one line per interval (and always the last item's).
  Progress(std::string what, std::size_t total, std::size_t already, Mode mode,
           std::chrono::milliseconds line_interval = std::chrono::milliseconds(0), std::FILE* out = stderr);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Text before the bracket of each plain line ("basin " gives "ambler: basin [3/40] ...").
  void setLinePrefix(std::string prefix) { prefix_ = std::move(prefix); }
  // An item finished. Lines: prints "ambler: [done/total] <line>". Bar: redraws (at most ten times
  // a second, and always for the last item). Not thread-safe: callers hold their own lock.
  void step(const std::string& line);
  // A message line ("ambler: <line>"), in both modes; the bar is cleared first and redrawn after.
  void note(const std::string& line);
  // Text for another stream (a table row on stdout) printed above the bar, which is redrawn after.
  void print(std::FILE* stream, const std::string& text);
  // Ends the bar (its last state stays on the screen); notes after it are plain lines.
  void finish();
  std::size_t done() const { return done_; }

 private:
  void draw();
  void clear();
  std::string what_;
  std::size_t total_, resumed_, done_;
  Mode mode_;
  std::FILE* out_;
  std::string detail_, prefix_;
  std::chrono::milliseconds line_interval_;
  std::chrono::steady_clock::time_point start_, last_draw_;
  bool drawn_ = false;
  std::size_t lines_ = 0;  // plain lines printed
};

}  // namespace ambler::eval
