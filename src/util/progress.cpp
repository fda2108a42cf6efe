// # implicit: progress bar

#include "progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>

namespace implicit {

// -----------------------------------------------------------------------------
// FORMATTING
// -----------------------------------------------------------------------------

// Width of the bar in characters, as in Yocto's print_progress.
static constexpr int progress_bar_width = 20;

// A time in seconds as mm:ss.
std::string format_duration(double seconds) {
  // Bound the value before the integer conversion (NaN and inf included);
  // a billion seconds is far past any render.
  const auto max_seconds = 1e9;
  if (!(seconds > 0)) seconds = 0;
  seconds    = std::min(seconds, max_seconds);
  auto whole = (long long)seconds;
  char buffer[64];
  std::snprintf(
      buffer, sizeof(buffer), "%02lld:%02lld", whole / 60, whole % 60);
  return buffer;
}

double estimate_remaining(
    int current, int total, double elapsed_seconds, double limit) {
  total   = std::max(total, 0);
  current = std::clamp(current, 0, total);
  if (current == total) return 0;
  if (current == 0) return -1;
  auto eta = std::max(elapsed_seconds, 0.0) * (total - current) / current;
  return limit > 0 ? std::max(std::min(eta, limit - elapsed_seconds), 0.0)
                   : eta;
}

// The progress line: bar, counts, elapsed, ETA, message.
std::string format_progress(const std::string& message, int current, int total,
    double elapsed_seconds, double limit, double converged) {
  total   = std::max(total, 0);
  current = std::clamp(current, 0, total);
  // An empty task is complete: a full bar and no time left.
  auto filled = total > 0
                    ? (int)((long long)progress_bar_width * current / total)
                    : progress_bar_width;
  auto line   = "[" + std::string((size_t)filled, '=') +
              std::string((size_t)(progress_bar_width - filled), ' ') + "] ";
  char counts[64];
  std::snprintf(counts, sizeof(counts), "%4d/%4d ", current, total);
  line += counts;
  line += format_duration(elapsed_seconds);
  auto eta = estimate_remaining(current, total, elapsed_seconds, limit);
  line += " eta " + (eta < 0 ? std::string{"--:--"} : format_duration(eta));
  if (converged >= 0) {
    char percent[32];
    std::snprintf(percent, sizeof(percent), " conv %d%%",
        (int)(100 * std::clamp(converged, 0.0, 1.0)));
    line += percent;
  }
  if (!message.empty()) line += " " + message;
  return line;
}

// -----------------------------------------------------------------------------
// PRINTING
// -----------------------------------------------------------------------------

// Minimum time between two redraws, so that fast updates do not flood stderr.
static constexpr double progress_redraw_seconds = 0.1;

// Seconds since the bar started.
static double elapsed_seconds(const progress_state& progress) {
  return std::chrono::duration<double>(
      std::chrono::steady_clock::now() - progress.start)
      .count();
}

// Rewrite the line in place, padding over a longer previous line.
static void print_progress(progress_state& progress, double elapsed) {
  auto line   = format_progress(progress.message, progress.current,
        progress.total, elapsed, progress.limit, progress.converged);
  auto length = line.size();
  if (line.size() < progress.last_length)
    line += std::string(progress.last_length - line.size(), ' ');
  std::fputs(("\r" + line).c_str(), progress.stream);
  std::fflush(progress.stream);
  progress.last_print  = elapsed;
  progress.last_length = length;
}

// Start a bar at 0/total.
void start_progress(progress_state& progress, const std::string& message,
    int total, bool enabled) {
  progress.enabled     = enabled;
  progress.message     = message;
  progress.total       = total;
  progress.current     = 0;
  progress.start       = std::chrono::steady_clock::now();
  progress.last_print  = -1;
  progress.last_length = 0;
  if (progress.enabled) print_progress(progress, 0);
}

// Set the samples done and redraw when due.
void update_progress(progress_state& progress, int current) {
  progress.current = current;
  if (!progress.enabled) return;
  auto elapsed = elapsed_seconds(progress);
  if (current >= progress.total ||
      elapsed - progress.last_print >= progress_redraw_seconds)
    print_progress(progress, elapsed);
}

// Redraw the final state and end the line.
void end_progress(progress_state& progress) {
  if (!progress.enabled) return;
  print_progress(progress, elapsed_seconds(progress));
  std::fputs("\n", progress.stream);
  std::fflush(progress.stream);
  progress.enabled = false;
}

// Whether stderr is a terminal.
bool stderr_is_terminal() { return isatty(fileno(stderr)) != 0; }

}  // namespace implicit
