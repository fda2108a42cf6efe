// # ypathtrace: the job on the ranks of an mpirun (see render_run.h)
//
// Only the transport lives here: the MPI calls and the threads around them.
// What is rendered, in which items and in which order, is the library's
// render_queue; the images are written by the driver (render_run.cpp).
//
// Rank 0 starts rendering before MPI is up: a worker thread loads the scene,
// starts the queue and renders items while the main thread starts MPI (on
// one machine MPI_Init waits a quarter of a second for the launcher), then
// broadcasts the scene bundle and serves the other ranks. Only the main
// thread calls MPI (MPI_THREAD_FUNNELED).
//
// Each rank > 0 holds up to two items, one rendering and the next waiting,
// so it never waits for rank 0's answer between items (near the end of a job
// only one, so that no rank sits on an item while another is idle). Its main
// thread moves the bytes while a worker thread renders. Every send is
// non-blocking, and every wait is polling with short sleeps: a blocking MPI
// call spins a core that rendering needs.

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <list>
#include <mutex>
#include <thread>

#include "render_run.h"
#include "scene/scene_bundle.h"
#include "util/error.h"

#ifdef IMPLICIT_MPI
#include <mpi.h>

namespace implicit {

// -----------------------------------------------------------------------------
// MESSAGES
// -----------------------------------------------------------------------------

enum message_tag : int { tag_ready = 1, tag_result, tag_work, tag_done };

// Items a rank > 0 holds at most (one rendering, one waiting).
inline constexpr int rank_items = 2;

// Waiting between polls: the pause doubles from 50 us to 8 ms while nothing
// happens, and starts again after a message. Each wake costs tens of
// microseconds of CPU (the sleep, not the probe), so the pause grows long:
// a rank holds its next item while it renders one (tens of milliseconds or
// more), so rank 0 may answer late without anyone waiting.
struct poll_backoff {
  std::chrono::microseconds pause = std::chrono::microseconds(50);
};

static void pause_briefly(poll_backoff& backoff) {
  std::this_thread::sleep_for(backoff.pause);
  backoff.pause = std::min(backoff.pause * 2, std::chrono::microseconds(8000));
}

// A non-blocking send and its bytes, kept until it completes.
struct pending_send {
  MPI_Request request = MPI_REQUEST_NULL;
  std::string bytes   = "";
};

static void send_async(
    std::list<pending_send>& sends, std::string bytes, int rank, int tag) {
  sends.push_back({MPI_REQUEST_NULL, std::move(bytes)});
  auto& send = sends.back();
  MPI_Isend(send.bytes.data(), (int)send.bytes.size(), MPI_BYTE, rank, tag,
      MPI_COMM_WORLD, &send.request);
}

// Forget the sends that completed; whether any did.
static bool complete_sends(std::list<pending_send>& sends) {
  auto completed = false;
  for (auto send = sends.begin(); send != sends.end();) {
    auto flag = 0;
    MPI_Test(&send->request, &flag, MPI_STATUS_IGNORE);
    if (flag) {
      send      = sends.erase(send);
      completed = true;
    } else {
      ++send;
    }
  }
  return completed;
}

// A message from `source` if one arrived: its tag and bytes.
static bool poll_message(int source, int& tag, int& rank, std::string& bytes) {
  auto status = MPI_Status{};
  auto flag   = 0;
  MPI_Iprobe(source, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
  if (!flag) return false;
  auto count = 0;
  MPI_Get_count(&status, MPI_BYTE, &count);
  bytes.assign((size_t)count, '\0');
  MPI_Recv(bytes.data(), count, MPI_BYTE, status.MPI_SOURCE, status.MPI_TAG,
      MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  tag  = status.MPI_TAG;
  rank = status.MPI_SOURCE;
  return true;
}

// Broadcast bytes from rank 0, in pieces that fit MPI's int counts.
static void broadcast_bytes(std::string& bytes) {
  auto size = (uint64_t)bytes.size();
  MPI_Bcast(&size, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  bytes.resize(size);
  constexpr auto piece = uint64_t{1} << 30;
  for (auto offset = uint64_t{0}; offset < size; offset += piece)
    MPI_Bcast(bytes.data() + offset, (int)std::min(piece, size - offset),
        MPI_BYTE, 0, MPI_COMM_WORLD);
}

// Start MPI on this (the main) thread; returns the rank count.
static int start_mpi(int& rank) {
#ifdef OPEN_MPI
  // OpenMPI's default point-to-point layer probes high-speed fabrics first:
  // 0.2 s of start-up per job on one machine. Tiles are small messages, so
  // ob1 (shared memory, TCP, InfiniBand verbs) serves as well; a user's own
  // OMPI_MCA_pml wins (no overwrite).
  setenv("OMPI_MCA_pml", "ob1", 0);
#endif
  auto provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  auto size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (provided < MPI_THREAD_FUNNELED) {
    if (rank == 0)
      std::fprintf(stderr,
          "ypathtrace: error: the MPI library does not support threads "
          "(MPI_THREAD_FUNNELED)\n");
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return size;
}

// End the whole job after printing `error` (rank > 0 names itself).
[[noreturn]] static void abort_job(int rank, const std::string& error) {
  std::fprintf(stderr, "ypathtrace: error: %s%s\n",
      rank > 0 ? ("rank " + std::to_string(rank) + ": ").c_str() : "",
      error.c_str());
  MPI_Abort(MPI_COMM_WORLD, 1);
  std::abort();  // MPI_Abort does not return; this satisfies [[noreturn]]
}

// -----------------------------------------------------------------------------
// RANK 0
// -----------------------------------------------------------------------------

// What rank 0's threads share while starting.
struct rank0_start {
  std::mutex              mutex   = {};
  std::condition_variable changed = {};
  int                     ranks   = 0;  // once MPI started (or the launcher's)
  bool                    loaded  = false;
  bool                    failed  = false;
  std::string             bundle  = "";
};

// Rank 0's worker: load the scene, start the job, render items.
static void run_rank0_worker(const run_options& options, rank0_start& start,
    run_setup& setup, run_state& state) {
  try {
    auto ranks = 0;
    {
      auto lock = std::unique_lock<std::mutex>{start.mutex};
      start.changed.wait(lock, [&] { return start.ranks > 0; });
      ranks = start.ranks;
    }
    setup       = make_run_setup(options.scene, options, ranks, true);
    auto bundle = serialize_bundle(
        make_scene_bundle(options.scene, setup.context->scene));
    start_run(state, setup, options, ranks, false);
    auto lock    = std::lock_guard<std::mutex>{start.mutex};
    start.bundle = std::move(bundle);
    start.loaded = true;
    start.changed.notify_all();
  } catch (const std::exception& error) {
    std::fprintf(stderr, "ypathtrace: error: %s\n", error.what());
    auto lock    = std::lock_guard<std::mutex>{start.mutex};
    start.failed = true;
    start.changed.notify_all();
    return;
  }
  try {
    render_queue_items(state.queue, *setup.context, save_run_output, &state);
  } catch (const std::exception& error) {
    stop_render_queue(state.queue, error.what());
  }
}

// Hand an idle rank items, or tell it that none are left. Returns whether
// anything was sent.
static bool feed_rank(run_state& state, int rank, int ranks,
    std::vector<int>& held, std::vector<bool>& listening, int& released,
    std::list<pending_send>& sends) {
  auto sent = false;
  while (listening[rank] && held[rank] < rank_items) {
    auto left = unassigned_items(state.queue);
    if (left == 0) {
      send_async(sends, {}, rank, tag_done);
      listening[rank] = false;
      released++;
      return true;
    }
    if (held[rank] > 0 && left <= ranks) break;  // near the end: one each
    auto item = take_item(state.queue);
    if (!item) break;
    send_async(sends, pack_item(*item), rank, tag_work);
    held[rank]++;
    sent = true;
  }
  return sent;
}

// Rank 0's main thread: receive results, hand out items, until every item
// came back and every rank was released.
static void serve_ranks(run_state& state, int ranks) {
  auto held      = std::vector<int>(ranks, 0);
  auto listening = std::vector<bool>(ranks, false);
  auto released  = 0;
  auto sends     = std::list<pending_send>{};
  auto backoff   = poll_backoff{};
  auto bytes     = std::string{};
  while (true) {
    auto busy = false;
    auto tag = 0, rank = 0;
    while (poll_message(MPI_ANY_SOURCE, tag, rank, bytes)) {
      busy = true;
      if (tag == tag_ready) listening[rank] = true;
      if (tag != tag_result) continue;
      held[rank]--;
      for (auto& output : finish_item(state.queue, unpack_item(bytes)))
        save_run_output(&state, output);
    }
    for (auto other = 1; other < ranks; other++)
      busy |= feed_rank(state, other, ranks, held, listening, released, sends);
    busy |= complete_sends(sends);
    auto error = render_queue_error(state.queue);
    if (!error.empty()) abort_job(0, error);
    if (released == ranks - 1 && sends.empty() &&
        unfinished_items(state.queue) == 0)
      return;
    if (busy) {
      backoff = {};
    } else {
      pause_briefly(backoff);
    }
  }
}

static int run_rank0(const run_options& options, int launcher_ranks) {
  auto start  = rank0_start{};
  start.ranks = launcher_ranks;
  auto setup  = run_setup{};
  auto state  = run_state{};
  auto worker =
      std::thread([&] { run_rank0_worker(options, start, setup, state); });
  auto rank  = 0;
  auto ranks = start_mpi(rank);
  auto ok    = 0;
  {
    auto lock   = std::unique_lock<std::mutex>{start.mutex};
    start.ranks = ranks;
    start.changed.notify_all();
    start.changed.wait(lock, [&] { return start.loaded || start.failed; });
    ok = start.loaded;
  }
  MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (!ok) {
    worker.join();
    MPI_Finalize();
    return 1;
  }
  broadcast_bytes(start.bundle);
  try {
    serve_ranks(state, ranks);
  } catch (const std::exception& error) { abort_job(0, error.what()); }
  worker.join();
  auto code = end_run(state, render_queue_error(state.queue).empty());
  MPI_Finalize();
  return code;
}

// -----------------------------------------------------------------------------
// RANKS > 0
// -----------------------------------------------------------------------------

// Items between a rank's main thread (MPI) and its worker.
struct rank_items_channel {
  std::mutex              mutex   = {};
  std::condition_variable changed = {};
  std::deque<render_item> inbox   = {};
  std::deque<render_item> outbox  = {};
  bool                    closing = false;  // rank 0 sent no more items
  bool                    exited  = false;  // the worker is done
  std::string             error   = "";
};

// Notify under the lock, so that a waiter cannot miss it.
static void notify(rank_items_channel& channel) {
  channel.changed.notify_all();
}

// The worker of a rank > 0: render items as they arrive.
static void run_rank_worker(
    const run_setup& setup, rank_items_channel& channel) {
  while (true) {
    auto item = render_item{};
    {
      auto lock = std::unique_lock<std::mutex>{channel.mutex};
      channel.changed.wait(
          lock, [&] { return !channel.inbox.empty() || channel.closing; });
      if (channel.inbox.empty()) {
        channel.exited = true;
        notify(channel);
        return;
      }
      item = std::move(channel.inbox.front());
      channel.inbox.pop_front();
    }
    try {
      auto camera = item_camera(setup.plan, setup.camera, item.frame);
      render_item_samples(
          *setup.context, setup.params, camera, setup.plan, item);
    } catch (const std::exception& error) {
      auto lock      = std::lock_guard<std::mutex>{channel.mutex};
      channel.error  = error.what();
      channel.exited = true;
      notify(channel);
      return;
    }
    auto lock = std::lock_guard<std::mutex>{channel.mutex};
    channel.outbox.push_back(std::move(item));
    notify(channel);
  }
}

// A rank > 0's main thread: pass items to the worker and results back,
// until rank 0 sends no more and every result is sent. It polls MPI only
// while it holds fewer items than rank_items (rank 0 is about to send one)
// or a send is in flight; otherwise it sleeps until the worker finishes.
static void serve_rank_zero(const run_setup& setup, int rank) {
  auto channel = rank_items_channel{};
  auto worker  = std::thread([&] { run_rank_worker(setup, channel); });
  auto sends   = std::list<pending_send>{};
  auto backoff = poll_backoff{};
  auto bytes   = std::string{};
  auto held    = 0;  // items received whose result is not sent yet
  send_async(sends, {}, 0, tag_ready);
  while (true) {
    auto busy = false;
    auto tag = 0, source = 0;
    while (poll_message(0, tag, source, bytes)) {
      busy      = true;
      auto lock = std::lock_guard<std::mutex>{channel.mutex};
      if (tag == tag_work) {
        channel.inbox.push_back(unpack_item(bytes));
        held++;
      }
      if (tag == tag_done) channel.closing = true;
      notify(channel);
    }
    auto finished = std::deque<render_item>{};
    auto exited   = false;
    auto closing  = false;
    {
      auto lock = std::lock_guard<std::mutex>{channel.mutex};
      if (!channel.error.empty()) abort_job(rank, channel.error);
      finished.swap(channel.outbox);
      exited  = channel.exited;
      closing = channel.closing;
    }
    for (auto& item : finished) {
      send_async(sends, pack_item(item), 0, tag_result);
      held--;
      busy = true;
    }
    busy |= complete_sends(sends);
    if (exited && sends.empty()) break;
    if (busy) {
      backoff = {};
    } else if ((held < rank_items && !closing) || !sends.empty()) {
      pause_briefly(backoff);
    } else {
      auto lock = std::unique_lock<std::mutex>{channel.mutex};
      channel.changed.wait(
          lock, [&] { return !channel.outbox.empty() || channel.exited; });
    }
  }
  worker.join();
}

// A rank > 0: receive the scene, load it, serve rank 0.
static int run_rank(const run_options& options) {
  auto rank  = 0;
  auto ranks = start_mpi(rank);
  auto ok    = 0;
  MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (!ok) {
    MPI_Finalize();
    return 1;
  }
  auto bytes = std::string{};
  broadcast_bytes(bytes);
  auto setup = run_setup{};
  try {
    // A loaded scene holds its files' contents: the copy goes at once.
    auto folder   = temporary_folder{};
    auto filename = write_scene_bundle(deserialize_bundle(bytes), folder);
    setup         = make_run_setup(filename, options, ranks, false);
    serve_rank_zero(setup, rank);
  } catch (const std::exception& error) { abort_job(rank, error.what()); }
  MPI_Finalize();
  return 0;
}

int run_ranks(const run_options& options) {
  return is_primary_process() ? run_rank0(options, launched_ranks())
                              : run_rank(options);
}

}  // namespace implicit

#endif
