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

render_plan make_render_plan(vec2i size, int samples, int savebatch,
    int turntable, const std::vector<int>& frames, int tile_size, int workers) {
  if (size.x < 1 || size.y < 1 || samples < 1 || savebatch < 0 ||
      turntable < 0 || tile_size < 1 || workers < 1)
    throw io_error("render plan: sizes and counts must be positive");
  auto plan      = render_plan{};
  plan.width     = size.x;
  plan.height    = size.y;
  plan.samples   = samples;
  plan.turntable = turntable;
  plan.frames    = frames;
  plan.savebatch = savebatch > 0;
  auto step      = savebatch > 0 ? savebatch : samples;
  for (auto s0 = 0; s0 < samples; s0 += step)
    plan.batches.push_back({s0, std::min(s0 + step, samples)});
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

// The header: frame, tile, batch, x0, x1, y0, y1, s0, s1, whether the sums
// follow, whether the streams follow.
inline constexpr int item_header_size = 11;

// Append an array's bytes (an empty vector's data() may be null).
template <typename T>
static void pack_array(std::string& bytes, const std::vector<T>& values) {
  if (values.empty()) return;
  bytes.append((const char*)values.data(), values.size() * sizeof(T));
}

std::string pack_item(const render_item& item) {
  int  header[item_header_size] = {item.frame, item.tile, item.batch,
       item.rect.x0, item.rect.x1, item.rect.y0, item.rect.y1, item.s0, item.s1,
       !item.sums.empty(), !item.rngs.empty()};
  auto bytes                    = std::string{};
  bytes.append((const char*)header, sizeof(header));
  pack_array(bytes, item.sums);
  pack_array(bytes, item.rngs);
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
  item.rect  = {header[3], header[4], header[5], header[6]};
  item.s0    = header[7];
  item.s1    = header[8];
  auto& rect = item.rect;
  if (item.frame < 0 || item.tile < 0 || item.batch < 0 || rect.x0 < 0 ||
      rect.y0 < 0 || rect.x1 < rect.x0 || rect.y1 < rect.y0 || item.s0 < 0 ||
      item.s1 < item.s0)
    throw io_error("work item: bad header");
  auto count  = rect_pixels(rect);
  auto offset = sizeof(header);
  unpack_array(bytes, offset, header[9] ? count : 0, item.sums);
  unpack_array(bytes, offset, header[10] ? count : 0, item.rngs);
  if (offset != bytes.size()) throw io_error("work item: wrong size");
  return item;
}

bool render_item_samples(const render_context& context,
    const trace_params& params, const camera_data& camera,
    const render_plan& plan, render_item& item,
    const render_callbacks& callbacks) {
  auto buffer = make_render_buffer(item.rect, plan.width, params.seed);
  auto count  = rect_pixels(item.rect);
  if ((!item.sums.empty() && item.sums.size() != count) ||
      (!item.rngs.empty() && item.rngs.size() != count))
    throw io_error("work item: sums or streams do not match its tile");
  if (!item.sums.empty()) buffer.sums = std::move(item.sums);
  if (!item.rngs.empty()) buffer.rngs = std::move(item.rngs);
  if (!render_samples(
          context, params, camera, item.s0, item.s1, buffer, callbacks))
    return false;
  item.sums = std::move(buffer.sums);
  item.rngs = std::move(buffer.rngs);
  if (item.s1 == plan.samples) item.rngs = {};
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
    job.buffer  = make_render_buffer(
         {0, plan.width, 0, plan.height}, plan.width, queue.params.seed);
    job.tiles_done.assign(plan.batches.size(), 0);
    for (auto tile = 0; tile < (int)plan.tiles.size(); tile++) {
      auto item  = render_item{};
      item.frame = frame;
      item.tile  = tile;
      item.rect  = plan.tiles[tile];
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
  auto& buffer = queue.active.at(item.frame).buffer;
  auto  width  = (size_t)queue.plan.width;
  for (auto j = item.rect.y0; j < item.rect.y1; j++) {
    for (auto i = item.rect.x0; i < item.rect.x1; i++) {
      item.sums.push_back(buffer.sums[j * width + i]);
      item.rngs.push_back(buffer.rngs[j * width + i]);
    }
  }
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

// Copy an item's sums into an image-wide array, and its streams when it has
// them and `rngs` is not null.
static void copy_item(const render_item& item, int width,
    std::vector<vec4f>& sums, std::vector<rng_state>* rngs) {
  auto k = size_t{0};
  for (auto j = item.rect.y0; j < item.rect.y1; j++) {
    for (auto i = item.rect.x0; i < item.rect.x1; i++, k++) {
      auto idx  = (size_t)j * width + i;
      sums[idx] = item.sums[k];
      if (rngs && !item.rngs.empty()) (*rngs)[idx] = item.rngs[k];
    }
  }
}

// Report the job's progress. Call with the mutex held.
static void report_progress(render_queue& queue) {
  auto& callbacks = queue.callbacks;
  if (callbacks.progress)
    callbacks.progress(
        callbacks.user, queue.done + queue.rendering, queue.total);
}

std::vector<render_output> finish_item(
    render_queue& queue, const render_item& item) {
  auto  lock    = std::lock_guard<std::mutex>{queue.mutex};
  auto& plan    = queue.plan;
  auto  outputs = std::vector<render_output>{};
  auto  found   = queue.active.find(item.frame);
  if (found == queue.active.end() || item.batch >= (int)plan.batches.size() ||
      item.tile >= (int)plan.tiles.size() ||
      item.sums.size() != rect_pixels(plan.tiles[item.tile]))
    throw io_error("work item: not one the queue handed out");
  auto& job  = found->second;
  auto  last = (int)plan.batches.size() - 1;
  copy_item(item, plan.width, job.buffer.sums, &job.buffer.rngs);
  if (item.batch < last) {
    auto next  = render_item{};
    next.frame = item.frame;
    next.tile  = item.tile;
    next.batch = item.batch + 1;
    next.rect  = item.rect;
    queue.ready.push_back(next);
    if (plan.savebatch) {
      auto& sums = job.batch_sums[item.batch];
      if (sums.empty()) sums.assign(job.buffer.sums.size(), {0, 0, 0, 0});
      copy_item(item, plan.width, sums, nullptr);
    }
  }
  queue.unfinished--;
  queue.done += (int64_t)rect_pixels(item.rect) * (item.s1 - item.s0);
  report_progress(queue);
  queue.changed.notify_all();
  if (++job.tiles_done[item.batch] < (int)plan.tiles.size()) return outputs;
  if (item.batch == last) {
    outputs.push_back(
        {item.frame, item.s1, true, average_samples(job.buffer, item.s1)});
    queue.active.erase(found);
  } else if (plan.savebatch) {
    auto sums = render_buffer{};
    sums.rect = {0, plan.width, 0, plan.height};
    sums.sums = std::move(job.batch_sums.at(item.batch));
    outputs.push_back(
        {item.frame, item.s1, false, average_samples(sums, item.s1)});
    job.batch_sums.erase(item.batch);
  }
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
