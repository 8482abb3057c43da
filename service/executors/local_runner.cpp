#include "executors/local_runner.h"

#include <unistd.h>

#include <thread>
#include <vector>

namespace millsim {
namespace {

struct Active {
  Claim claim;
  ExecHandle handle;
  double last_heartbeat = 0.0;
};

}  // namespace

void run_study_locally(Store& store, const std::string& study_id, Executor& executor,
                       const LocalRunOptions& options) {
  run_studies_locally(store, {study_id}, executor, options);
}

void run_studies_locally(Store& store, const std::vector<std::string>& study_ids,
                         Executor& executor, const LocalRunOptions& options) {
  const std::string worker = "local-" + std::to_string(getpid());
  std::vector<Active> active;
  auto total_progress = [&] {
    Progress sum;
    for (const std::string& id : study_ids) {
      const Progress p = store.progress(id);
      sum.total += p.total;
      for (int s = 0; s < 7; ++s) sum.by_state[s] += p.by_state[s];
    }
    return sum;
  };
  auto report = [&] {
    if (options.on_progress) options.on_progress(total_progress());
  };
  std::size_t next_study = 0;  // studies before it have no queued run left
  report();
  while (true) {
    double now = wall_clock_s();
    if (store.requeue_expired(now) > 0) report();
    while (int(active.size()) < options.workers && next_study < study_ids.size()) {
      std::optional<Claim> claim = store.claim(worker, options.lease_s, now, study_ids[next_study]);
      if (!claim) {
        ++next_study;
        continue;
      }
      Active a{*claim, {}, now};
      try {
        a.handle = executor.start(claim->run, now);
      } catch (const std::exception& e) {
        FinishReport failed;
        failed.state = RunState::SystemError;
        failed.retryable = true;
        failed.error = std::string("could not start the run: ") + e.what();
        store.finish(claim->run.id, claim->token, failed, now);
        report();
        continue;
      }
      active.push_back(std::move(a));
      report();
    }
    for (std::size_t k = 0; k < active.size();) {
      Active& a = active[k];
      now = wall_clock_s();
      if (std::optional<ChildExit> done = executor.poll(a.handle, now)) {
        store.finish(a.claim.run.id, a.claim.token, report_from_exit(*done, a.handle.out_dir), now);
        active.erase(active.begin() + std::ptrdiff_t(k));
        report();
        continue;
      }
      if (now - a.last_heartbeat > options.lease_s / 3.0) {
        a.last_heartbeat = now;
        // A refused heartbeat: the run was canceled (or taken from us): stop the child.
        if (!store.heartbeat(a.claim.run.id, a.claim.token, options.lease_s, now))
          executor.cancel(a.handle, now);
      }
      ++k;
    }
    if (active.empty() && total_progress().finished()) break;
    if (next_study == study_ids.size()) next_study = 0;  // expired leases queue runs again
    std::this_thread::sleep_for(std::chrono::duration<double>(options.poll_interval_s));
  }
}

}  // namespace millsim
