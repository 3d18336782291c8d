#include "eval/tools/progress.hpp"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace ambler::eval {
namespace {

std::size_t terminalWidth(std::FILE* out) {
  winsize ws{};
  if (::ioctl(::fileno(out), TIOCGWINSZ, &ws) == 0 && ws.ws_col >= 20) return ws.ws_col;
  return 80;
}

}  // namespace

std::string clockText(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0 || seconds > 360000) return "--:--";
  const long s = std::lround(seconds);
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  }
  return buf;
}

std::string progressBar(std::string_view what, std::size_t done, std::size_t total, std::size_t resumed,
                        double elapsed_s, std::string_view detail, std::size_t width) {
  constexpr std::size_t kBar = 20;
  const double fraction = total ? double(std::min(done, total)) / double(total) : 1.0;
  const std::size_t filled = std::size_t(std::floor(fraction * double(kBar)));
  std::string bar(kBar, ' ');
  std::fill_n(bar.begin(), filled, '=');
  if (filled < kBar && done > 0) bar[filled] = '>';
  const std::size_t fresh = done >= resumed ? done - resumed : 0;
  const double rate = elapsed_s > 0 && fresh > 0 ? double(fresh) / elapsed_s : NAN;
  const double left = std::isfinite(rate) ? double(total - std::min(done, total)) / rate : NAN;
  char rate_text[32];
  if (std::isfinite(rate)) {
    std::snprintf(rate_text, sizeof rate_text, rate >= 10 ? "%.0f/s" : rate >= 1 ? "%.1f/s" : "%.2f/s", rate);
  } else {
    std::snprintf(rate_text, sizeof rate_text, "-/s");
  }
  char head[160];
  std::snprintf(head, sizeof head, "%.*s [%s] %zu/%zu %3.0f%%  %s  ETA %s", int(what.size()), what.data(),
                bar.c_str(), done, total, 100.0 * fraction, rate_text, done >= total ? "0:00" : clockText(left).c_str());
  std::string line = head;
  if (!detail.empty()) line += "  " + std::string(detail);
  if (line.size() > width) line.resize(width);
  return line;
}

Progress::Mode Progress::modeFor(bool enabled) {
  if (!enabled) return Mode::Off;
  if (const char* forced = std::getenv("AMBLER_PROGRESS")) {
    if (std::strcmp(forced, "lines") == 0) return Mode::Lines;
    if (std::strcmp(forced, "bar") == 0) return Mode::Bar;
  }
  const char* term = std::getenv("TERM");
  const bool dumb = !term || std::strcmp(term, "dumb") == 0;
  return ::isatty(::fileno(stderr)) && !dumb ? Mode::Bar : Mode::Lines;
}

Progress::Progress(std::string what, std::size_t total, std::size_t already, Mode mode,
                   std::chrono::milliseconds line_interval, std::FILE* out)
    : what_(std::move(what)),
      total_(total),
      resumed_(already),
      done_(already),
      mode_(mode),
      out_(out),
      line_interval_(line_interval),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {
  if (mode_ == Mode::Bar) draw();
}

Progress::~Progress() { finish(); }

void Progress::finish() {
  if (mode_ != Mode::Bar) return;
  if (drawn_) {
    draw();
    std::fputc('\n', out_);
    std::fflush(out_);
    drawn_ = false;
  }
  mode_ = Mode::Lines;  // notes from here on are plain lines
}

void Progress::step(const std::string& line) {
  ++done_;
  const auto now = std::chrono::steady_clock::now();
  if (mode_ == Mode::Lines) {
    if (lines_ > 0 && now - last_draw_ < line_interval_ && done_ < total_) return;
    ++lines_;
    last_draw_ = now;
    std::fprintf(out_, "ambler: %s[%zu/%zu] %s\n", prefix_.c_str(), done_, total_, line.c_str());
  } else if (mode_ == Mode::Bar) {
    detail_ = line;
    if (now - last_draw_ >= std::chrono::milliseconds(100) || done_ >= total_) draw();
  }
}

void Progress::note(const std::string& line) {
  if (mode_ == Mode::Off) return;
  clear();
  std::fprintf(out_, "ambler: %s\n", line.c_str());
  if (mode_ == Mode::Bar) draw();
}

void Progress::print(std::FILE* stream, const std::string& text) {
  const bool redraw = drawn_;
  clear();
  std::fflush(out_);
  std::fputs(text.c_str(), stream);
  std::fflush(stream);
  if (redraw) draw();
}

void Progress::clear() {
  if (mode_ == Mode::Bar && drawn_) {
    std::fputs("\r\x1b[K", out_);
    drawn_ = false;
  }
}

void Progress::draw() {
  last_draw_ = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(last_draw_ - start_).count();
  const std::string line =
      progressBar("ambler: " + what_, done_, total_, resumed_, elapsed, detail_, terminalWidth(out_) - 1);
  std::fprintf(out_, "\r\x1b[K%s", line.c_str());
  std::fflush(out_);
  drawn_ = true;
}

}  // namespace ambler::eval
