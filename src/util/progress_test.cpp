// Tests for the progress bar: the formatted line and what gets printed.

#include "progress.h"

#include <doctest/doctest.h>

#include <cstdio>
#include <limits>
#include <string>

namespace implicit {

// Everything written to a temporary stream so far.
static std::string read_stream(std::FILE* stream) {
  std::fflush(stream);
  std::rewind(stream);
  auto text = std::string{};
  char buffer[256];
  while (auto count = std::fread(buffer, 1, sizeof(buffer), stream))
    text.append(buffer, count);
  return text;
}

TEST_CASE("progress format_duration") {
  CHECK(format_duration(0) == "00:00");
  CHECK(format_duration(59.9) == "00:59");
  CHECK(format_duration(60) == "01:00");
  CHECK(format_duration(3725.5) == "62:05");
  CHECK(format_duration(6000) == "100:00");
  CHECK(format_duration(-5) == "00:00");
  CHECK(format_duration(std::numeric_limits<double>::quiet_NaN()) == "00:00");
  CHECK(format_duration(std::numeric_limits<double>::infinity()) ==
        "16666666:40");
}

TEST_CASE("progress format_progress known lines") {
  // A quarter done in 4 s: 5 of 20 cells, 12 s to go at the same pace.
  CHECK(format_progress("render image", 16, 64, 4.0) ==
        "[=====               ]   16/  64 00:04 eta 00:12 render image");
  // Nothing done yet: no estimate.
  CHECK(format_progress("render", 0, 64, 0.0) ==
        "[                    ]    0/  64 00:00 eta --:-- render");
  // One of three: the bar rounds down (20/3 = 6), eta = 10 s * 2.
  CHECK(format_progress("render", 1, 3, 10.0) ==
        "[======              ]    1/   3 00:10 eta 00:20 render");
  // Done.
  CHECK(format_progress("render", 64, 64, 125.7) ==
        "[====================]   64/  64 02:05 eta 00:00 render");
  // Counts wider than four digits widen the line, and no message, no space.
  CHECK(format_progress("", 5000, 10000, 61) ==
        "[==========          ] 5000/10000 01:01 eta 01:01");
  // A time budget of 30 s caps the estimate (12 s -> 26 s left of 30 s is
  // more, 40 s of work left is capped to the 26 s); the converged fraction.
  CHECK(format_progress("r", 16, 64, 4.0, 30) ==
        "[=====               ]   16/  64 00:04 eta 00:12 r");
  CHECK(format_progress("r", 1, 11, 4.0, 30, 0.375) ==
        "[=                   ]    1/  11 00:04 eta 00:26 conv 37% r");
}

TEST_CASE("progress format_progress clamps bad counts") {
  CHECK(format_progress("m", 100, 64, 1) == format_progress("m", 64, 64, 1));
  CHECK(format_progress("m", -3, 64, 1) == format_progress("m", 0, 64, 1));
  // An empty task is complete.
  CHECK(format_progress("m", 0, 0, 1) ==
        "[====================]    0/   0 00:01 eta 00:00 m");
  CHECK(format_progress("m", 0, -5, 1) == format_progress("m", 0, 0, 1));
  // Negative elapsed time (a clock hiccup) reads as zero.
  CHECK(format_progress("m", 1, 2, -3) ==
        "[==========          ]    1/   2 00:00 eta 00:00 m");
}

TEST_CASE("progress printing when enabled") {
  auto stream = std::tmpfile();
  REQUIRE(stream != nullptr);
  auto progress   = progress_state{};
  progress.stream = stream;
  start_progress(progress, "render", 4, true);
  CHECK(progress.current == 0);
  CHECK(read_stream(stream) ==
        "\r[                    ]    0/   4 00:00 eta --:-- render");
  // The last step always redraws, whatever the throttle says.
  update_progress(progress, 4);
  CHECK(progress.current == 4);
  auto text = read_stream(stream);
  CHECK(text.find("\r[====================]    4/   4 ") != std::string::npos);
  CHECK(text.back() != '\n');
  end_progress(progress);
  text = read_stream(stream);
  CHECK(text.back() == '\n');
  CHECK_FALSE(progress.enabled);
  // Ending twice prints nothing more.
  end_progress(progress);
  CHECK(read_stream(stream) == text);
  std::fclose(stream);
}

TEST_CASE("progress printing pads over a longer line") {
  auto stream = std::tmpfile();
  REQUIRE(stream != nullptr);
  auto progress   = progress_state{};
  progress.stream = stream;
  start_progress(progress, "a long message", 2, true);
  auto first = read_stream(stream);
  // Same state, shorter message: the new line is padded to the old length.
  progress.message = "short";
  end_progress(progress);
  auto text   = read_stream(stream);
  auto second = text.substr(first.size());
  CHECK(second.size() == first.size() + 1);  // plus the newline
  CHECK(second.substr(0, second.find("short") + 5) ==
        "\r[                    ]    0/   2 00:00 eta --:-- short");
  CHECK(second.back() == '\n');
  std::fclose(stream);
}

TEST_CASE("progress printing when disabled") {
  auto stream = std::tmpfile();
  REQUIRE(stream != nullptr);
  auto progress   = progress_state{};
  progress.stream = stream;
  start_progress(progress, "render", 10, false);
  update_progress(progress, 3);
  CHECK(progress.current == 3);
  update_progress(progress, 10);
  end_progress(progress);
  CHECK(read_stream(stream).empty());
  std::fclose(stream);
}

TEST_CASE(
    "progress: the time left is the mean step time times the steps left") {
  CHECK(estimate_remaining(16, 64, 4.0) == 12.0);
  CHECK(estimate_remaining(1, 3, 10.0) == 20.0);
  CHECK(estimate_remaining(0, 64, 1.0) < 0);  // unknown
  CHECK(estimate_remaining(64, 64, 9.0) == 0);
  CHECK(estimate_remaining(70, 64, 9.0) == 0);  // clamped
  // A time limit caps it, never below zero.
  CHECK(estimate_remaining(16, 64, 4.0, 10.0) == 6.0);
  CHECK(estimate_remaining(16, 64, 4.0, 3.0) == 0);
}

}  // namespace implicit
