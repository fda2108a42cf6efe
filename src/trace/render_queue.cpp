// # implicit: work items of distributed renders and sequences
// (implementation)

#include "render_queue.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "../util/error.h"

namespace implicit {

// -----------------------------------------------------------------------------
// SEQUENCES
// -----------------------------------------------------------------------------

camera_data turntable_camera(const camera_data& camera, int frame, int frames) {
  auto angle  = 2 * pif * (float)frame / (float)frames;
  auto c      = std::cos(angle);
  auto s      = std::sin(angle);
  auto rotate = [&](vec3f v) {
    return vec3f{c * v.x + s * v.z, v.y, -s * v.x + c * v.z};
  };
  auto& from   = camera.frame;
  auto  focus  = from.o - from.z * camera.focus;  // the camera looks down -z
  auto  result = camera;
  result.frame = {rotate(from.x), rotate(from.y), rotate(from.z),
      focus + rotate(from.o - focus)};
  return result;
}

// out.png -> out<tag>0016.png: a number of at least 4 digits before the
// extension (the last dot of the file name; none: at the end).
static std::string numbered_filename(
    const std::string& output, const std::string& tag, int number) {
  auto slash  = output.find_last_of('/');
  auto dot    = output.find_last_of('.');
  auto digits = std::to_string(number);
  while (digits.size() < 4) digits = "0" + digits;
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
    return output + tag + digits;
  return output.substr(0, dot) + tag + digits + output.substr(dot);
}

std::string frame_filename(const std::string& output, int frame) {
  return numbered_filename(output, "-", frame);
}

std::string batch_filename(const std::string& output, int samples) {
  return numbered_filename(output, "-s", samples);
}

std::vector<int> frames_to_render(const std::string& output, int turntable) {
  if (turntable == 0) return {0};
  auto frames = std::vector<int>{};
  for (auto frame = 0; frame < turntable; frame++)
    if (!std::filesystem::exists(frame_filename(output, frame)))
      frames.push_back(frame);
  return frames;
}

// -----------------------------------------------------------------------------
// PLAN
// -----------------------------------------------------------------------------

// Largest frame whose sums and streams go whole to a worker (one message).
inline constexpr double max_frame_item_bytes = 1e9;

// Ends of the batches of a plan: every `savebatch` samples, and with a time
// budget the passes (1, 2, 4, ... 64, then every 64), then `samples`.
static std::vector<vec2i> plan_batches(int samples, int savebatch, float time) {
  auto ends = std::vector<int>{samples};
  for (auto s = savebatch; savebatch > 0 && s < samples; s += savebatch)
    ends.push_back(s);
  for (auto s = 1; time > 0 && s < samples; s += std::min(s, max_pass_samples))
    ends.push_back(s);
  std::sort(ends.begin(), ends.end());
  ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
  auto batches = std::vector<vec2i>{};
  for (auto k = 0; k < (int)ends.size(); k++)
    batches.push_back({k > 0 ? ends[k - 1] : 0, ends[k]});
  return batches;
}

render_plan make_render_plan(vec2i size, int samples, int savebatch,
    int turntable, const std::vector<int>& frames, int tile_size, int workers,
    float time) {
  if (size.x < 1 || size.y < 1 || samples < 1 || savebatch < 0 ||
      turntable < 0 || tile_size < 1 || workers < 1 || !(time >= 0))
    throw io_error("render plan: sizes and counts must be positive");
  auto plan      = render_plan{};
  plan.width     = size.x;
  plan.height    = size.y;
  plan.samples   = samples;
  plan.turntable = turntable;
  plan.frames    = frames;
  plan.savebatch = savebatch;
  plan.time      = time;
  plan.batches   = plan_batches(samples, savebatch, time);
  auto frame_bytes =
      (double)size.x * size.y * (sizeof(vec4f) + sizeof(rng_state));
  auto whole =
      workers == 1 || (turntable > 0 && (int)frames.size() >= workers &&
                          frame_bytes < max_frame_item_bytes);
  if (whole) {
    plan.tiles = {{0, size.x, 0, size.y}};
  } else {
    for (auto y = 0; y < size.y; y += tile_size)
      for (auto x = 0; x < size.x; x += tile_size)
        plan.tiles.push_back({x, std::min(x + tile_size, size.x), y,
            std::min(y + tile_size, size.y)});
  }
  plan.active_frames = whole ? workers : 2;
  return plan;
}

// -----------------------------------------------------------------------------
// WORK ITEMS
// -----------------------------------------------------------------------------

// The header: frame, tile, batch, x0, x1, y0, y1, s0, s1, then one bit per
// array of visit_pixel_arrays() that follows.
inline constexpr int item_header_size = 10;

// Append an array's bytes (an empty vector's data() may be null).
template <typename T>
static void pack_array(std::string& bytes, const std::vector<T>& values) {
  if (values.empty()) return;
  bytes.append((const char*)values.data(), values.size() * sizeof(T));
}

std::string pack_item(const render_item& item) {
  auto& rect   = item.data.rect;
  auto  arrays = 0, bit = 1;
  visit_pixel_arrays(item.data, item.data, [&](const auto& array, const auto&) {
    if (!array.empty()) arrays |= bit;
    bit <<= 1;
  });
  int  header[item_header_size] = {item.frame, item.tile, item.batch, rect.x0,
       rect.x1, rect.y0, rect.y1, item.s0, item.s1, arrays};
  auto bytes                    = std::string{};
  bytes.append((const char*)header, sizeof(header));
  visit_pixel_arrays(item.data, item.data,
      [&](const auto& array, const auto&) { pack_array(bytes, array); });
  return bytes;
}

// Copy `count` values from `bytes` at `offset`, advancing it.
template <typename T>
static void unpack_array(const std::string& bytes, size_t& offset, size_t count,
    std::vector<T>& values) {
  if ((bytes.size() - offset) / sizeof(T) < count)
    throw io_error("work item: truncated");
  values.resize(count);
  if (count == 0) return;  // an empty vector's data() may be null
  std::memcpy(values.data(), bytes.data() + offset, count * sizeof(T));
  offset += count * sizeof(T);
}

render_item unpack_item(const std::string& bytes) {
  int header[item_header_size] = {};
  if (bytes.size() < sizeof(header)) throw io_error("work item: truncated");
  std::memcpy(header, bytes.data(), sizeof(header));
  auto item  = render_item{};
  item.frame = header[0];
  item.tile  = header[1];
  item.batch = header[2];
  item.s0    = header[7];
  item.s1    = header[8];
  auto& rect = item.data.rect;
  rect       = {header[3], header[4], header[5], header[6]};
  if (item.frame < 0 || item.tile < 0 || item.batch < 0 || rect.x0 < 0 ||
      rect.y0 < 0 || rect.x1 < rect.x0 || rect.y1 < rect.y0 || item.s0 < 0 ||
      item.s1 < item.s0 || header[9] < 0 || header[9] >= (1 << 9))
    throw io_error("work item: bad header");
  auto count  = rect_pixels(rect);
  auto offset = sizeof(header);
  auto bit    = 1;
  visit_pixel_arrays(item.data, item.data, [&](auto& array, auto&) {
    unpack_array(bytes, offset, (header[9] & bit) ? count : 0, array);
    bit <<= 1;
  });
  if (offset != bytes.size()) throw io_error("work item: wrong size");
  return item;
}

bool render_item_samples(const render_context& context,
    const trace_params& params, const camera_data& camera,
    const render_plan& plan, render_item& item,
    const render_callbacks& callbacks) {
  auto buffer = make_render_buffer(
      item.data.rect, plan.width, params.seed, render_layout(params));
  auto count = rect_pixels(item.data.rect);
  auto fits  = true;
  visit_pixel_arrays(item.data, item.data, [&](const auto& array, const auto&) {
    fits = fits && (array.empty() || array.size() == count);
  });
  if (!fits) throw io_error("work item: its arrays do not match its tile");
  copy_pixels(item.data, buffer);
  if (!render_samples(
          context, params, camera, item.s0, item.s1, buffer, callbacks))
    return false;
  item.data             = std::move(buffer);
  item.data.evaluations = {};
  if (item.s1 == plan.samples) item.data.rngs = {};
  return true;
}

// -----------------------------------------------------------------------------
// QUEUE
// -----------------------------------------------------------------------------

std::string output_filename(const std::string& output, const render_plan& plan,
    const render_output& out) {
  auto name = plan.turntable > 0 ? frame_filename(output, out.frame) : output;
  return out.final ? name : batch_filename(name, out.samples);
}

void start_render_queue(render_queue& queue, const render_plan& plan,
    const trace_params& params, const camera_data& camera,
    const render_callbacks& callbacks) {
  auto lock        = std::lock_guard<std::mutex>{queue.mutex};
  queue.plan       = plan;
  queue.params     = params;
  queue.camera     = camera;
  queue.callbacks  = callbacks;
  queue.next_frame = 0;
  queue.active.clear();
  queue.ready.clear();
  auto items = (int64_t)plan.frames.size() * (int64_t)plan.tiles.size() *
               (int64_t)plan.batches.size();
  queue.unassigned = items;
  queue.unfinished = items;
  queue.done       = 0;
  queue.rendering  = 0;
  queue.converged  = params.noise_threshold > 0 ? 0 : -1;
  queue.total =
      (int64_t)plan.frames.size() * plan.width * plan.height * plan.samples;
  queue.error = "";
  queue.stopped.store(false);
}

camera_data item_camera(
    const render_plan& plan, const camera_data& camera, int frame) {
  return plan.turntable > 0 ? turntable_camera(camera, frame, plan.turntable)
                            : camera;
}

// Start the frames the queue may hold and queue their first batch. Call with
// the mutex held.
static void activate_frames(render_queue& queue) {
  auto& plan = queue.plan;
  while (queue.ready.empty() && queue.next_frame < plan.frames.size() &&
         (int)queue.active.size() < plan.active_frames) {
    auto  frame = plan.frames[queue.next_frame++];
    auto& job   = queue.active[frame];
    // The frame gathers its tiles, which bring their pixels' streams.
    auto layout    = render_layout(queue.params);
    layout.streams = false;
    job.buffer     = make_render_buffer(
            {0, plan.width, 0, plan.height}, plan.width, queue.params.seed, layout);
    job.tiles_done.assign(plan.batches.size(), 0);
    job.start   = std::chrono::steady_clock::now();
    job.pending = (int)plan.tiles.size();
    job.tile_batch.assign(plan.tiles.size(), 0);
    job.tile_converged.assign(plan.tiles.size(), 0);
    for (auto tile = 0; tile < (int)plan.tiles.size(); tile++) {
      auto item      = render_item{};
      item.frame     = frame;
      item.tile      = tile;
      item.data.rect = plan.tiles[tile];
      queue.ready.push_back(item);
    }
  }
}

// The next ready item with its data. Call with the mutex held.
static std::optional<render_item> take_ready(render_queue& queue) {
  activate_frames(queue);
  if (queue.ready.empty()) return std::nullopt;
  auto item = std::move(queue.ready.front());
  queue.ready.pop_front();
  queue.unassigned--;
  auto batch = queue.plan.batches[item.batch];
  item.s0    = batch.x;
  item.s1    = batch.y;
  if (item.batch == 0) return item;  // zero sums, the pixels' own streams
  copy_pixels(queue.active.at(item.frame).buffer, item.data);
  return item;
}

std::optional<render_item> take_item(render_queue& queue) {
  auto lock = std::lock_guard<std::mutex>{queue.mutex};
  if (!queue.error.empty()) return std::nullopt;
  return take_ready(queue);
}

std::optional<render_item> wait_item(render_queue& queue) {
  auto lock = std::unique_lock<std::mutex>{queue.mutex};
  auto item = std::optional<render_item>{};
  queue.changed.wait(lock, [&] {
    if (!queue.error.empty() || queue.unassigned == 0) return true;
    auto next = take_ready(queue);
    if (next) item.emplace(std::move(*next));
    return item.has_value();
  });
  return item;
}

// Report the job's progress. Call with the mutex held.
static void report_progress(render_queue& queue) {
  auto& callbacks = queue.callbacks;
  if (callbacks.progress)
    callbacks.progress(
        callbacks.user, queue.done + queue.rendering, queue.total);
}

// Count the item's pixels that adaptive sampling stopped into its frame's
// and the queue's counts. Call with the mutex held.
static void count_converged(
    render_queue& queue, render_frame& job, const render_item& item) {
  if (queue.params.noise_threshold <= 0) return;
  auto stopped = int64_t{0};
  for (auto count : item.data.counts) stopped += count < item.s1;
  job.converged += stopped - job.tile_converged[item.tile];
  job.tile_converged[item.tile] = stopped;
  queue.converged =
      (double)job.converged / ((double)queue.plan.width * queue.plan.height);
}

// End a frame at batch `batch` (its time budget ran out): drop its items
// that wait and the later batches not made yet; those rendering are
// dropped when they come back. Call with the mutex held.
static void end_frame(
    render_queue& queue, render_frame& job, int frame, int batch) {
  auto last     = (int)queue.plan.batches.size() - 1;
  job.end_batch = batch;
  for (auto it = queue.ready.begin(); it != queue.ready.end();) {
    if (it->frame != frame) {
      ++it;
      continue;
    }
    it = queue.ready.erase(it);
    queue.unassigned--, queue.unfinished--, job.pending--;
  }
  for (auto tile_batch : job.tile_batch) {
    queue.unassigned -= last - tile_batch;
    queue.unfinished -= last - tile_batch;
  }
}

// The images a frame's finished batch completes. Call with the mutex held.
static void batch_outputs(render_queue& queue, render_frame& job,
    const render_item& item, std::vector<render_output>& outputs) {
  auto& plan    = queue.plan;
  auto  last    = (int)plan.batches.size() - 1;
  auto  elapsed = std::chrono::duration<double>(
      std::chrono::steady_clock::now() - job.start)
                     .count();
  if (item.batch == last) {
    auto image      = output_image(job.buffer, queue.params);
    job.buffer.rngs = {};
    outputs.push_back(
        {item.frame, item.s1, true, std::move(image), std::move(job.buffer)});
    return;
  }
  auto found = job.batch_data.find(item.batch);
  if (found == job.batch_data.end()) return;
  auto data = std::move(found->second);
  job.batch_data.erase(found);
  data.rngs  = {};
  auto ended = plan.time > 0 && elapsed >= plan.time;
  auto saved = plan.savebatch > 0 && item.s1 % plan.savebatch == 0;
  if (!ended && !saved) return;
  auto image = output_image(data, queue.params);
  outputs.push_back(
      {item.frame, item.s1, ended, std::move(image), std::move(data)});
  if (ended) end_frame(queue, job, item.frame, item.batch);
}

std::vector<render_output> finish_item(
    render_queue& queue, const render_item& item) {
  auto  lock    = std::lock_guard<std::mutex>{queue.mutex};
  auto& plan    = queue.plan;
  auto  outputs = std::vector<render_output>{};
  auto  found   = queue.active.find(item.frame);
  auto& rect    = item.data.rect;
  if (found == queue.active.end() || item.batch >= (int)plan.batches.size() ||
      item.tile >= (int)plan.tiles.size() ||
      item.data.sums.size() != rect_pixels(plan.tiles[item.tile]) ||
      item.data.counts.size() != item.data.sums.size())
    throw io_error("work item: not one the queue handed out");
  auto& job  = found->second;
  auto  last = (int)plan.batches.size() - 1;
  queue.unfinished--;
  job.pending--;
  queue.done += (int64_t)rect_pixels(rect) * (item.s1 - item.s0);
  if (job.end_batch >= 0) {
    // Its frame ended at the time budget: dropped.
    if (job.pending == 0) queue.active.erase(found);
    report_progress(queue);
    queue.changed.notify_all();
    return outputs;
  }
  copy_pixels(item.data, job.buffer);
  count_converged(queue, job, item);
  if (item.batch < last) {
    auto next      = render_item{};
    next.frame     = item.frame;
    next.tile      = item.tile;
    next.batch     = item.batch + 1;
    next.data.rect = rect;
    queue.ready.push_back(next);
    job.pending++;
    job.tile_batch[item.tile] = next.batch;
    if (plan.savebatch > 0 || plan.time > 0) {
      auto& data = job.batch_data[item.batch];
      data.rect  = job.buffer.rect;
      copy_pixels(item.data, data);
    }
  }
  report_progress(queue);
  queue.changed.notify_all();
  if (++job.tiles_done[item.batch] < (int)plan.tiles.size()) return outputs;
  batch_outputs(queue, job, item, outputs);
  if (item.batch == last || (job.end_batch >= 0 && job.pending == 0))
    queue.active.erase(found);
  return outputs;
}

int64_t unassigned_items(render_queue& queue) {
  auto lock = std::lock_guard<std::mutex>{queue.mutex};
  return queue.unassigned;
}

int64_t unfinished_items(render_queue& queue) {
  auto lock = std::lock_guard<std::mutex>{queue.mutex};
  return queue.unfinished;
}

void stop_render_queue(render_queue& queue, const std::string& error) {
  auto lock = std::lock_guard<std::mutex>{queue.mutex};
  if (queue.error.empty()) queue.error = error.empty() ? "stopped" : error;
  queue.stopped.store(true);
  queue.changed.notify_all();
}

std::string render_queue_error(render_queue& queue) {
  auto lock = std::lock_guard<std::mutex>{queue.mutex};
  return queue.error;
}

// Progress of this process's item, within the job's.
static void on_item_progress(void* user, int64_t done, int64_t) {
  auto& queue     = *(render_queue*)user;
  auto  lock      = std::lock_guard<std::mutex>{queue.mutex};
  queue.rendering = done;
  report_progress(queue);
}

// The user's cancel, or a stopped queue.
static bool on_item_cancel(void* user) {
  auto& queue     = *(render_queue*)user;
  auto& callbacks = queue.callbacks;
  return queue.stopped.load(std::memory_order_relaxed) ||
         (callbacks.cancel && callbacks.cancel(callbacks.user));
}

bool render_queue_items(render_queue& queue, const render_context& context,
    render_save save, void* user) {
  auto callbacks = render_callbacks{on_item_progress, on_item_cancel, &queue};
  while (auto item = wait_item(queue)) {
    auto camera = item_camera(queue.plan, queue.camera, item->frame);
    if (!render_item_samples(
            context, queue.params, camera, queue.plan, *item, callbacks)) {
      stop_render_queue(queue, "cancelled");
      return false;
    }
    {
      auto lock       = std::lock_guard<std::mutex>{queue.mutex};
      queue.rendering = 0;
    }
    for (auto& output : finish_item(queue, *item))
      if (save) save(user, output);
  }
  return !queue.stopped.load();
}

}  // namespace implicit
