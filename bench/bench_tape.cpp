// # bench_tape: point evaluations per second of the tape (issue 22)
//
// A 2D model of a few thousand `.vm` clauses (as Keeter's Prospero challenge
// uses: `min`, `max`, `sqrt`, `square`, `abs`): a union of seeded discs and
// rectangles, written to a `.vm` file so that bench/numpy_vm_eval.py can
// evaluate the same expression; then the tape, compiled once, evaluates a
// grid of points single-threaded, batched (eval_sdf of many points), and one
// point at a time. Prints clauses, CPU seconds and evaluations per second,
// and the mean value as a checksum that the NumPy evaluator prints too.
//
// Usage: bench_tape [--vm out.vm] [--shapes N] [--grid N] [--repeat N]

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "math/random.h"
#include "sdf/sdf_tape.h"
#include "sdf/sdf_vm_io.h"

using namespace implicit;

static double cpu_seconds() {
  auto now = timespec{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

// The union of `count` shapes over [-1, 1]^2: discs (sqrt of a sum of
// squares) and rectangles (max of two |offsets|), 8 clauses each.
static sdf_program make_model(int count, uint64_t seed) {
  auto program = sdf_program{};
  auto rng     = make_rng(seed);
  auto node    = [&](sdf_type type, int a = invalidid, int b = invalidid) {
    auto n  = sdf_node{};
    n.type  = type;
    n.left  = a;
    n.right = b;
    return add_node(program, n);
  };
  auto number = [&](float value) {
    auto n  = sdf_node{};
    n.type  = sdf_type::math_const;
    n.value = value;
    return add_node(program, n);
  };
  auto x    = node(sdf_type::math_x);
  auto y    = node(sdf_type::math_y);
  auto root = invalidid;
  for (auto i = 0; i < count; i++) {
    auto cx = number(rand1f(rng) * 2 - 1), cy = number(rand1f(rng) * 2 - 1);
    auto dx    = node(sdf_type::math_sub, x, cx),
         dy    = node(sdf_type::math_sub, y, cy);
    auto shape = invalidid;
    if (i % 2 == 0) {
      auto r2 = node(sdf_type::math_add, node(sdf_type::math_square, dx),
          node(sdf_type::math_square, dy));
      shape   = node(sdf_type::math_sub, node(sdf_type::math_sqrt, r2),
            number(0.01f + 0.04f * rand1f(rng)));
    } else {
      auto w = number(0.01f + 0.04f * rand1f(rng));
      auto h = number(0.01f + 0.04f * rand1f(rng));
      shape  = node(sdf_type::math_max,
           node(sdf_type::math_sub, node(sdf_type::math_abs, dx), w),
           node(sdf_type::math_sub, node(sdf_type::math_abs, dy), h));
    }
    root = root < 0 ? shape : node(sdf_type::math_min, root, shape);
  }
  return program;
}

int main(int argc, char** argv) {
  auto vm     = std::string{"bench_tape.vm"};
  auto shapes = 400;
  auto grid   = 512;
  auto repeat = 3;
  for (auto i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--vm")) {
      vm = argv[i + 1];
    } else if (!std::strcmp(argv[i], "--shapes")) {
      shapes = std::atoi(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--grid")) {
      grid = std::atoi(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--repeat")) {
      repeat = std::atoi(argv[i + 1]);
    } else {
      std::fprintf(stderr, "bench_tape: unknown option %s\n", argv[i]);
      return 1;
    }
  }
  auto program = make_model(shapes, 5);
  save_vm(vm, program);
  // The tape of the file, as a scene would load it.
  auto loaded = sdf_program{};
  load_vm(loaded, vm);
  auto tape   = make_sdf_tape(loaded);
  auto points = std::vector<vec3f>{};
  for (auto j = 0; j < grid; j++)
    for (auto i = 0; i < grid; i++)
      points.push_back(
          {(i + 0.5f) / grid * 2 - 1, (j + 0.5f) / grid * 2 - 1, 0});
  auto values     = std::vector<float>(points.size());
  auto best_batch = 1e30, best_march = 1e30, best_single = 1e30;
  for (auto r = 0; r < repeat; r++) {
    auto start = cpu_seconds();
    eval_sdf(tape, points.data(), values.data(), points.size());
    best_batch = std::min(best_batch, cpu_seconds() - start);
    // As a march asks: a few points at a time (sdf_march_lane_count).
    start = cpu_seconds();
    for (size_t k = 0; k < points.size(); k += 8)
      eval_sdf(tape, points.data() + k, values.data() + k,
          std::min((size_t)8, points.size() - k));
    best_march = std::min(best_march, cpu_seconds() - start);
    start      = cpu_seconds();
    for (size_t k = 0; k < points.size(); k++)
      values[k] = eval_sdf(tape, points[k]);
    best_single = std::min(best_single, cpu_seconds() - start);
  }
  auto mean = 0.0;
  for (auto v : values) mean += v;
  mean /= (double)values.size();
  auto n = (double)points.size();
  std::printf("file %s: %zu clauses, %d x %d points (z = 0)\n", vm.c_str(),
      tape.clauses.size(), grid, grid);
  std::printf("tape, batched:      %.3f s, %.2f M evaluations/s\n", best_batch,
      n / best_batch * 1e-6);
  std::printf("tape, batches of 8: %.3f s, %.2f M evaluations/s\n", best_march,
      n / best_march * 1e-6);
  std::printf("tape, single point: %.3f s, %.2f M evaluations/s\n", best_single,
      n / best_single * 1e-6);
  std::printf("mean value %.6f\n", mean);
  return 0;
}
