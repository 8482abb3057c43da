#include "local_runner.h"

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
  const std::string worker = "local-" + std::to_string(getpid());
  std::vector<Active> active;
  auto report = [&] {
    if (options.on_progress) options.on_progress(store.progress(study_id));
  };
  report();
  while (true) {
    double now = wall_clock_s();
    if (store.requeue_expired(now) > 0) report();
    while (int(active.size()) < options.workers) {
      std::optional<Claim> claim = store.claim(worker, options.lease_s, now, study_id);
      if (!claim) break;
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
    if (active.empty() && store.progress(study_id).finished()) break;
    std::this_thread::sleep_for(std::chrono::duration<double>(options.poll_interval_s));
  }
}

}  // namespace millsim
