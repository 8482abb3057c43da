// The batch service as real processes on loopback: `millsim serve` with its SQLite file and
// worker processes, driven over HTTP and through the CLI. A study finishes and serves its
// results and PSDs; a worker killed with SIGKILL loses its run to another attempt; a server
// stopped and restarted mid-study resumes it; cancel stops running children; bad requests get
// their documented 4xx and change nothing. Every process a test starts is stopped by pid.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <ctime>
#include <fstream>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "parallel/thread_team.h"
#include "queue/store.h"
#include "support/process.h"
#include "support/scenes.h"

namespace millsim {
namespace {

using test::children_of;

using nlohmann::json;

constexpr const char* kToken = "test-token";

// A client for the server under test: no timeout shorter than 30 s, so a loaded machine slows
// the suite down instead of failing it (issue 32: a 5 s read timeout failed a test there).
httplib::Client client_for(const std::string& url) {
  httplib::Client c(url);
  c.set_connection_timeout(30);
  c.set_read_timeout(60);
  c.set_write_timeout(30);
  return c;
}

// A response that may be missing (a timeout, a refused connection). Reading a missing one throws,
// which fails the test naming the request, where dereferencing it crashed the whole suite.
class Reply {
 public:
  Reply(httplib::Result result, std::string request) : request_(std::move(request)) {
    if (result)
      response_ = *result;
    else
      error_ = httplib::to_string(result.error());
  }
  explicit operator bool() const { return response_.has_value(); }
  const httplib::Response* operator->() const { return &get(); }
  const httplib::Response& operator*() const { return get(); }

 private:
  const httplib::Response& get() const {
    if (!response_) throw std::runtime_error("no response to " + request_ + " (" + error_ + ")");
    return *response_;
  }
  std::string request_, error_;
  std::optional<httplib::Response> response_;
};

// A `millsim serve` child on a free loopback port; stopped (SIGTERM, then SIGKILL) by pid.
class ServerProcess {
 public:
  // `address_space_mb` > 0: the server's address space is limited to it (RLIMIT_AS), so a
  // request that wants more meets std::bad_alloc.
  ServerProcess(const std::filesystem::path& dir, int workers, double lease_s = 2.0,
                const std::string& scenes = ".", std::vector<std::string> extra = {},
                std::size_t address_space_mb = 0)
      : dir_(dir) {
    const std::filesystem::path log = dir / ("serve-" + std::to_string(++starts_) + ".log");
    pid_ = fork();
    if (pid_ == 0) {
      test::die_with_parent();
      if (chdir(dir.c_str()) != 0) _exit(99);
      freopen(log.c_str(), "w", stdout);
      freopen((log.string() + ".err").c_str(), "w", stderr);
      const std::string w = std::to_string(workers), lease = std::to_string(lease_s);
      setenv("MILLSIM_TOKEN", kToken, 1);  // as a systemd EnvironmentFile gives it
      if (address_space_mb > 0) {
        setenv("MALLOC_ARENA_MAX", "2", 1);  // each arena reserves 64 MB of address space
        const rlim_t bytes = rlim_t(address_space_mb) << 20;
        const struct rlimit limit = {bytes, bytes};
        setrlimit(RLIMIT_AS, &limit);
      }
      std::vector<std::string> args = {"millsim",    "serve",    "--port",
                                       "0",          "--db",     "q.db",
                                       "--workers",  w,          "--lease",
                                       lease,        "--out",    "runs",
                                       "--max-body", "200000",   "--max-study-bytes",
                                       "5000000",    "--scenes", scenes};
      args.insert(args.end(), extra.begin(), extra.end());
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(MILLSIM_BINARY, argv.data());
      _exit(98);
    }
    const std::regex listening("listening on (http://127.0.0.1:[0-9]+)");
    for (int k = 0; k < 200 && url_.empty(); ++k) {
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
      std::ifstream in(log);
      std::string line;
      std::smatch m;
      while (std::getline(in, line))
        if (std::regex_search(line, m, listening)) url_ = m[1];
    }
  }
  ~ServerProcess() { stop(); }

  void stop() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    for (int k = 0; k < 200; ++k) {
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

  const std::string& url() const { return url_; }
  pid_t pid() const { return pid_; }
  // What the server printed on stdout and stderr (its request log) so far.
  std::string output() const {
    std::ifstream out(dir_ / ("serve-" + std::to_string(starts_) + ".log"));
    std::ifstream err(dir_ / ("serve-" + std::to_string(starts_) + ".log.err"));
    std::stringstream text;
    text << out.rdbuf() << err.rdbuf();
    return text.str();
  }
  // Waits up to `timeout_s` for the output to match: the server logs a request after its
  // response is sent, so a client can hold the answer before the line is written.
  bool output_matches_within(const std::regex& pattern, double timeout_s) const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (!std::regex_search(output(), pattern)) {
      if (std::chrono::steady_clock::now() > end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
  }

  Reply get(const std::string& path, bool auth = false) const {
    httplib::Client c = client_for(url_);
    httplib::Headers h;
    if (auth) h.emplace("Authorization", std::string("Bearer ") + kToken);
    return Reply(c.Get(path.c_str(), h), "GET " + path);
  }
  Reply post(const std::string& path, const std::string& body, bool auth = true,
             httplib::Headers h = {}) const {
    httplib::Client c = client_for(url_);
    if (auth) h.emplace("Authorization", std::string("Bearer ") + kToken);
    return Reply(c.Post(path.c_str(), h, body, "application/json"), "POST " + path);
  }

  // Polls the study until no run is queued, running or canceling. The default wait is long (a
  // study under the sanitizers on a machine shared with other work took over 120 s): it only
  // decides how late a test that would fail anyway gives up.
  json wait_finished(const std::string& id, double timeout_s = 600.0) const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      auto res = get("/v1/studies/" + id);
      if (res && res->status == 200) {
        const json s = json::parse(res->body);
        if (s["progress"]["finished"].get<bool>()) return s;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return nullptr;
  }

 private:
  std::filesystem::path dir_;
  pid_t pid_ = -1;
  std::string url_;
  static inline int starts_ = 0;
};

// A study over the attrition case (outlets and breakage, so it has a PSD), quick runs.
json attrition_study(std::vector<double> thresholds, double end_s = 0.0004) {
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/attrition_target.json");
  const json scene = json::parse(in);
  return {{"name", "attrition"},
          {"scene", scene},
          {"set", {{"time.end_s", end_s}, {"output.h5", false}}},
          {"parameters", {{{"path", "dust.threshold_diameter_m"}, {"values", thresholds}}}},
          {"reference", {{"dust.threshold_diameter_m", thresholds.back()}}}};
}

// A study over the settling column: runs that take seconds (for kills, restarts and cancels).
json slow_study(int runs, double end_s) {
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/settling_column.json");
  json values = json::array();
  for (int k = 0; k < runs; ++k) values.push_back(0.3 + 0.1 * k);
  return {{"name", "slow"},
          {"scene", json::parse(in)},
          {"set", {{"time.end_s", end_s}, {"output.h5", false}}},
          {"parameters", {{{"path", "materials.0.restitution"}, {"values", values}}}}};
}

// Each local worker runs one run of at least one thread: no more workers than cores.
TEST(Service, MoreWorkersThanCoresAreRefused) {
  test::TempDir dir;
  const test::CommandResult r = test::run_millsim(
      "serve --port 0 --db q.db --workers " + std::to_string(usable_core_count() + 1), dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--workers"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("affinity mask"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "q.db"));
}

TEST(Service, StudyOverHttpFinishesWithResultsAndPsd) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 2);
  ASSERT_FALSE(server.url().empty()) << "the server did not start";
  // Runs of as many threads as there are cores, on two workers: more threads than cores.
  json greedy = attrition_study({1.2e-4});
  greedy["limits"] = {{"threads_per_run", usable_core_count()}};
  auto refused = server.post("/v1/studies", greedy.dump(), true);
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 400) << refused->body;
  EXPECT_NE(refused->body.find("/limits/threads_per_run"), std::string::npos) << refused->body;
  const auto none_queued = server.get("/v1/studies");
  ASSERT_TRUE(none_queued);
  EXPECT_EQ(json::parse(none_queued->body)["studies"].size(), 0u);

  auto res = server.post("/v1/studies", attrition_study({1.2e-4, 8e-5, 6e-5}).dump(), true,
                         {{"Idempotency-Key", "k1"}});
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["study"];
  // The same key again: the same study, nothing new.
  res = server.post("/v1/studies", attrition_study({1.2e-4, 8e-5, 6e-5}).dump(), true,
                    {{"Idempotency-Key", "k1"}});
  ASSERT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["study"], id);

  const json study = server.wait_finished(id);
  ASSERT_FALSE(study.is_null());
  EXPECT_EQ(study["progress"]["counts"]["COMPLETE"], 3);
  const json table = json::parse(server.get("/v1/studies/" + id + "/results")->body);
  EXPECT_EQ(table["error_metric"], "psd_ks");
  ASSERT_EQ(table["runs"].size(), 3u);
  EXPECT_EQ(table["runs"][2]["error"].get<double>(), 0.0);
  for (const json& row : table["runs"]) EXPECT_GT(row["d50_m"].get<double>(), 0.0);
  const json psd = json::parse(server.get("/v1/runs/" + id + "-r1/psd")->body);
  EXPECT_EQ(psd["outlet_psd"]["cumulative_mass"].size(), psd["outlet_psd"]["edges_m"].size());
  auto run = server.get("/v1/runs/" + id + "-r1");
  EXPECT_EQ(json::parse(run->body)["state"], "COMPLETE");
  auto plot = server.get("/v1/studies/" + id + "/plot/error-vs-time");
  EXPECT_NE(plot->body.find("<svg"), std::string::npos);
  // The attrition case breaks particles: each run has its impact spectrum, drawn by the API.
  auto spectrum = server.get("/v1/runs/" + id + "-r0/plot/impact-spectrum");
  ASSERT_TRUE(spectrum);
  EXPECT_EQ(spectrum->status, 200) << spectrum->body;
  EXPECT_EQ(spectrum->get_header_value("Content-Type"), "image/svg+xml");
  EXPECT_NE(spectrum->body.find("normal impact energy"), std::string::npos);
  EXPECT_EQ(server.get("/v1/runs/" + id + "-r99/plot/impact-spectrum")->status, 404);
  auto runs = server.get("/v1/studies/" + id + "/runs?state=COMPLETE&limit=2");
  EXPECT_EQ(json::parse(runs->body)["runs"].size(), 2u);

  // The CLI against the same server.
  test::write_file(dir.path() / "study.json", attrition_study({1e-4, 8e-5}).dump());
  test::write_file(dir.path() / "token", std::string(kToken) + "\n");
  const std::string common = " --server " + server.url() + " --token-file token";
  const test::CommandResult submitted =
      test::run_millsim("submit study.json --wait --format json" + common, dir.path());
  ASSERT_EQ(submitted.exit_code, 0) << submitted.err;
  const json cli_table = json::parse(submitted.out.substr(submitted.out.find('{')));
  EXPECT_EQ(cli_table["counts"]["COMPLETE"], 2);
  // Off a terminal --wait reports as runs end: the last line says both are done.
  EXPECT_NE(submitted.err.find(cli_table["study"].get<std::string>() +
                               " 2/2 done, running 0, failed 0\n"),
            std::string::npos)
      << submitted.err;
  const test::CommandResult psd_cli = test::run_millsim(
      "psd " + cli_table["study"].get<std::string>() + "-r0" + common, dir.path());
  EXPECT_EQ(psd_cli.exit_code, 0) << psd_cli.err;
  EXPECT_NE(psd_cli.out.find("cumulative_mass"), std::string::npos);
  const test::CommandResult listed = test::run_millsim("status" + common, dir.path());
  EXPECT_NE(listed.out.find(id), std::string::npos);
}

TEST(Service, BadRequestsGetTheirStatusAndChangeNothing) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 0);
  ASSERT_FALSE(server.url().empty());
  auto code = [](const Reply& r) { return r ? r->status : -1; };
  auto error_code = [](const Reply& r) {
    return json::parse(r->body)["error"]["code"].get<std::string>();
  };
  EXPECT_EQ(code(server.post("/v1/studies", "{}", false)), 401);  // no token
  auto r = server.post("/v1/studies", "{not json");
  EXPECT_EQ(code(r), 400);
  EXPECT_EQ(error_code(r), "invalid_json");
  json bad = attrition_study({1e-4});
  bad["parameters"][0]["path"] = "dust.treshold_diameter_m";  // unknown key
  r = server.post("/v1/studies", bad.dump());
  EXPECT_EQ(code(r), 400);
  EXPECT_EQ(error_code(r), "invalid_study");
  EXPECT_NE(r->body.find("did you mean"), std::string::npos);
  bad = attrition_study({1e-4});
  bad["parameters"][0]["values"] = "many";  // wrong type
  EXPECT_EQ(code(server.post("/v1/studies", bad.dump())), 400);
  bad = {{"scene", "../../etc/passwd"}};  // a path trick
  EXPECT_EQ(code(server.post("/v1/studies", bad.dump())), 400);
  EXPECT_EQ(code(server.post("/v1/studies", std::string(300000, ' '))), 413);  // huge body
  // Nested past the limit (64): a 400 naming it, and the server lives on.
  r = server.post("/v1/studies", std::string(50000, '[') + std::string(50000, ']'));
  EXPECT_EQ(code(r), 400);
  EXPECT_NE(r->body.find("deeper than 64 levels"), std::string::npos) << r->body;
  EXPECT_EQ(code(server.get("/v1/health")), 200);
  // 2,000 copies of one bad parameter: a reply of 100 listed problems, not hundreds of MB.
  bad = attrition_study({1e-4});
  bad["parameters"] = json::array();
  for (int k = 0; k < 2000; ++k)
    bad["parameters"].push_back({{"path", "dust.nothing"}, {"values", {1}}});
  r = server.post("/v1/studies", bad.dump());
  EXPECT_EQ(code(r), 400);
  EXPECT_LE(json::parse(r->body)["error"]["details"].size(), 100u);
  EXPECT_LT(r->body.size(), 100000u);
  EXPECT_EQ(code(server.get("/v1/runs/..%2F..%2Fetc%2Fpasswd")), 404);
  EXPECT_EQ(code(server.get("/v1/runs/s000001-r0;drop")), 404);
  EXPECT_EQ(code(server.get("/v1/studies/s999999")), 404);
  EXPECT_EQ(code(server.get("/v1/studies?limit=0")), 400);
  EXPECT_EQ(code(server.post("/v1/worker/runs/s000001-r0/finish", "{\"token\": \"x\"}")), 400);
  const json list = json::parse(server.get("/v1/studies")->body);
  EXPECT_TRUE(list["studies"].empty());  // nothing was stored
  EXPECT_EQ(json::parse(server.get("/v1/info")->body)["limits"]["max_body_bytes"], 200000);
}

// Every shipped study file, POSTed byte for byte to a server whose scenes folder is cases/, is
// queued with the runs its parameters make, each run holding the scene file it names.
TEST(Service, ShippedStudiesPostAsTheyAre) {
  test::TempDir dir;
  const std::filesystem::path cases = MILLSIM_SOURCE_DIR "/cases";
  ServerProcess server(dir.path(), 0, 2.0, cases.string());
  ASSERT_FALSE(server.url().empty());
  int studies = 0;
  for (const auto& entry : std::filesystem::directory_iterator(cases)) {
    const std::string file = entry.path().filename().string();
    if (file.size() < 11 || file.substr(file.size() - 11) != ".study.json") continue;
    SCOPED_TRACE(file);
    ++studies;
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    const json spec = json::parse(text.str());
    // The runs a grid or a zip of the parameter lists makes.
    std::size_t expected = spec.value("combine", "grid") == "zip" ? 0 : 1;
    for (const json& p : spec["parameters"])
      expected = spec.value("combine", "grid") == "zip" ? std::max(expected, p["values"].size())
                                                        : expected * p["values"].size();
    expected *= spec.value("repeats", 1);

    const auto posted = server.post("/v1/studies", text.str());
    ASSERT_TRUE(posted);
    ASSERT_EQ(posted->status, 201) << posted->body;
    const json reply = json::parse(posted->body);
    EXPECT_EQ(reply["runs"].get<std::size_t>(), expected);
    const std::string id = reply["study"];
    std::ifstream scene_in(cases / spec["scene"].get<std::string>());
    const json scene = json::parse(scene_in);
    Store store(dir.path() / "q.db");
    const std::optional<RunRecord> run = store.run(id + "-r0");
    ASSERT_TRUE(run);
    // The scene file it names (a study may set a material's property, never rename one).
    const json run_materials = json::parse(run->scene)["materials"];
    ASSERT_EQ(run_materials.size(), scene["materials"].size());
    for (std::size_t m = 0; m < run_materials.size(); ++m)
      EXPECT_EQ(run_materials[m]["name"], scene["materials"][m]["name"]);
    EXPECT_EQ(server.post("/v1/studies/" + id + "/cancel", "{}")->status, 200);
  }
  EXPECT_GE(studies, 6);
  // The same server still refuses a path out of its scenes folder.
  const json escaping = {{"scene", "../cases/attrition_target.json"}};
  EXPECT_EQ(server.post("/v1/studies", escaping.dump())->status, 400);
}

// Every file a submitted scene names stays inside the scenes root: absolute paths, "..", and a
// symlink out are refused with 400 before anything is opened, and the reply names the path but
// never carries what is there. A file inside the root is accepted.
TEST(Service, FilesNamedByASubmittedSceneStayInsideTheScenesRoot) {
  test::TempDir dir;
  const std::filesystem::path scenes = dir.path() / "scenes";
  std::filesystem::create_directories(scenes / "sub");
  test::write_file(dir.path() / "secret.txt", "# N: 1\n1 5e-4 5e-4 5e-4 1e-4 0 0 0 TOPSECRET\n");
  test::write_file(scenes / "p.txt", "# N: 1\n1 5e-4 5e-4 5e-4 1e-4 0 0 0\n");
  std::filesystem::create_symlink(dir.path() / "secret.txt", scenes / "link.txt");
  std::filesystem::create_directory_symlink(dir.path(), scenes / "sub" / "up");
  ServerProcess server(dir.path(), 0, 2.0, scenes.string());
  ASSERT_FALSE(server.url().empty());
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  const json base = json::parse(in);
  const auto submit = [&](const std::string& path) {
    json study = {{"name", "files"}, {"scene", base}};
    study["scene"]["sources"] = {
        {{"type", "file"}, {"material", base["materials"][0]["name"]}, {"path", path}}};
    return server.post("/v1/studies", study.dump());
  };
  for (const std::string& path : {(dir.path() / "secret.txt").string(),
                                  std::string("../secret.txt"), std::string("sub/../../secret.txt"),
                                  std::string("link.txt"), std::string("sub/up/secret.txt")}) {
    SCOPED_TRACE(path);
    const auto res = submit(path);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 400) << res->body;
    EXPECT_NE(res->body.find("/sources/0/path"), std::string::npos) << res->body;
    EXPECT_NE(res->body.find("scenes root"), std::string::npos) << res->body;
    EXPECT_EQ(res->body.find("TOPSECRET"), std::string::npos) << res->body;
  }
  const auto inside = submit("p.txt");
  ASSERT_TRUE(inside);
  EXPECT_EQ(inside->status, 201) << inside->body;
}

// A study's stored size is capped before anything is stored: 300 runs of a 20 kB inline scene
// (6 MB) exceed the test server's 5 MB with 413 and leave no study behind; 100 runs (2 MB) pass.
// Before, a 10 000-run study of a 900 kB scene would have put 9 GB of scenes in the database.
TEST(Service, AStudyThatWouldStoreTooMuchIsRefusedWhole) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 0);
  ASSERT_FALSE(server.url().empty());
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  json scene = json::parse(in);
  scene["description"] = std::string(20000, 'x');
  const auto study = [&](int runs) {
    json values = json::array();
    for (int k = 0; k < runs; ++k) values.push_back(1 + k);
    return json{{"name", "big"},
                {"scene", scene},
                {"parameters", {{{"path", "seed"}, {"values", values}}}}};
  };
  const auto big = server.post("/v1/studies", study(300).dump());
  ASSERT_TRUE(big);
  EXPECT_EQ(big->status, 413) << big->body;
  EXPECT_NE(big->body.find("study_too_large"), std::string::npos) << big->body;
  EXPECT_TRUE(json::parse(server.get("/v1/studies")->body)["studies"].empty());
  EXPECT_EQ(json::parse(server.get("/v1/info")->body)["limits"]["max_study_bytes"], 5000000);
  const auto fits = server.post("/v1/studies", study(100).dump());
  ASSERT_TRUE(fits);
  EXPECT_EQ(fits->status, 201) << fits->body;
}

// Writes are checked before their body is read: without the token a POST is 401 whatever it
// carries, and a body whose size cannot be bounded while it is read is refused, chunked with 411
// and compressed with 415 (a 1 MiB gzip body became 1 GiB in memory before). The server goes on
// answering and stores nothing.
TEST(Service, BodiesTheLimitCannotBoundAreRefusedBeforeTheyAreRead) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 0);
  ASSERT_FALSE(server.url().empty());
  // The server closes these connections without reading the body: a client still writing it
  // gets EPIPE, which must not kill this process.
  struct IgnoreSigpipe {
    void (*previous)(int) = signal(SIGPIPE, SIG_IGN);
    ~IgnoreSigpipe() { signal(SIGPIPE, previous); }
  } ignore_sigpipe;
  httplib::Client c = client_for(server.url());
  auto res = c.Post("/v1/studies", "{\"name\": \"x\"}", "application/json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 401) << res->body;
  const httplib::Headers auth = {{"Authorization", std::string("Bearer ") + kToken}};
  httplib::Client chunked = client_for(server.url());
  res = chunked.Post(
      "/v1/studies", auth,
      [](std::size_t, httplib::DataSink& sink) {
        sink.write("{}", 2);
        sink.done();
        return true;
      },
      "application/json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 411) << res->body;
  EXPECT_NE(res->body.find("length_required"), std::string::npos) << res->body;
  httplib::Headers gzip = auth;
  gzip.emplace("Content-Encoding", "gzip");
  httplib::Client encoded = client_for(server.url());
  res = encoded.Post("/v1/studies", gzip, std::string(1000, 'x'), "application/json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 415) << res->body;
  EXPECT_NE(res->body.find("gzip"), std::string::npos) << res->body;
  EXPECT_EQ(server.get("/v1/health")->status, 200);
  EXPECT_TRUE(json::parse(server.get("/v1/studies")->body)["studies"].empty());
}

// A request that runs the server out of memory fails alone (issue 33: a std::bad_alloc escaped
// a handler while other requests were in flight and the server died with SIGABRT). The server
// runs in 1.5 GB of address space; a study whose runs grow past it as they are expanded (a long
// text as a parameter value, times 4,000 seeds; the size bound cannot refuse it from the base
// scene, and the byte cap is raised out of the way) gets 503 out_of_memory, and the server goes
// on answering, storing and serving, also on a busy machine (service/memory_reserve.h).
TEST(Service, ARequestThatRunsOutOfMemoryFailsAloneAndTheServerLives) {
#if defined(MILLSIM_SANITIZED)
  GTEST_SKIP() << "ASan reserves terabytes of address space: no RLIMIT_AS under it";
#endif
  test::TempDir dir;
  ServerProcess server(dir.path(), 0, 2.0, ".",
                       {"--max-body", "1000000", "--max-study-bytes", "1e12", "--max-connections",
                        "8", "--max-runs", "100000"},
                       1536);
  ASSERT_FALSE(server.url().empty()) << server.output();
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  json scene = json::parse(in);
  // A 600 kB description, cheap to validate (a large particle list made this take minutes of
  // CPU on a busy machine before memory ran out), copied into every run.
  const std::string long_text(600000, 'x');
  json study = {{"name", "greedy"},
                {"scene", scene},
                {"parameters",
                 {{{"path", "seed"}, {"range", {{"from", 1}, {"to", 4000}, {"step", 1}}}},
                  {{"path", "description"}, {"values", {long_text}}}}}};
  const std::string body = study.dump();
  ASSERT_LT(body.size(), 1000000u);
  auto res = server.post("/v1/studies", body);
  ASSERT_TRUE(res) << "no answer: " << server.output().substr(0, 2000);
  EXPECT_EQ(res->status, 503) << res->body.substr(0, 400);
  EXPECT_NE(res->body.find("out_of_memory"), std::string::npos) << res->body.substr(0, 400);
  EXPECT_EQ(res->get_header_value("Retry-After"), "10");
  // The server lives: it answers, nothing of the study was stored, and a study fits afterwards.
  EXPECT_EQ(server.get("/v1/health")->status, 200);
  EXPECT_TRUE(json::parse(server.get("/v1/studies")->body)["studies"].empty());
  res = server.post("/v1/studies", slow_study(1, 0.001).dump());
  EXPECT_EQ(res->status, 201) << res->body;
  EXPECT_EQ(waitpid(server.pid(), nullptr, WNOHANG), 0) << "the server exited";
}

// Slow clients (slowloris: a request head dribbled a byte at a time, each byte inside httplib's
// per-read timeout) are cut at the receive deadline, connections over the cap are closed at
// once, and the worker protocol keeps answering on its own port meanwhile. Before, a dozen such
// connections stalled every endpoint and workers missed their heartbeats.
TEST(Service, SlowClientsAreCutAndWorkersKeepTheirOwnPath) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 0, 2.0, ".",
                       {"--max-connections", "8", "--receive-timeout", "1"});
  ASSERT_FALSE(server.url().empty());
  struct IgnoreSigpipe {
    void (*previous)(int) = signal(SIGPIPE, SIG_IGN);
    ~IgnoreSigpipe() { signal(SIGPIPE, previous); }
  } ignore_sigpipe;
  const json info = json::parse(server.get("/v1/info")->body);
  ASSERT_TRUE(info["worker_port"].is_number_integer()) << info.dump();
  EXPECT_EQ(info["limits"]["max_connections"], 8);
  const int public_port = std::stoi(server.url().substr(server.url().rfind(':') + 1));
  const int worker_port = info["worker_port"].get<int>();

  const auto open_socket = test::connect_loopback;
  // 24 slow clients, three times the cap, each starting a request head.
  const auto start = std::chrono::steady_clock::now();
  std::vector<int> slow;
  for (int k = 0; k < 24; ++k) {
    const int fd = open_socket(public_port);
    ASSERT_GE(fd, 0);
    const char head[] = "GET /v1/health HTTP/1.1\r\nHost: x\r\n";
    send(fd, head, sizeof head - 1, MSG_NOSIGNAL);
    slow.push_back(fd);
  }
  // The worker protocol answers on its own port while the public one is full.
  httplib::Client worker =
      client_for(std::string("http://127.0.0.1:") + std::to_string(worker_port));
  const auto claim =
      worker.Post("/v1/worker/claim", {{"Authorization", std::string("Bearer ") + kToken}},
                  "{\"worker\": \"w\"}", "application/json");
  ASSERT_TRUE(claim) << "the worker port did not answer while slow clients held the public one";
  EXPECT_EQ(claim->status, 204);  // nothing queued
  EXPECT_EQ(worker.Get("/v1/health")->status, 404) << "the worker port serves workers only";
  // Dribble a byte every 100 ms to each, and time when the server closes them.
  std::vector<double> closed_after(slow.size(), -1.0);
  for (int tick = 0; tick < 60; ++tick) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const double t =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    for (std::size_t k = 0; k < slow.size(); ++k) {
      if (closed_after[k] >= 0.0) continue;
      char buffer[4096];
      ssize_t n;
      while ((n = recv(slow[k], buffer, sizeof buffer, MSG_DONTWAIT)) > 0) {
      }  // whatever the server answered before closing
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK) ||
          send(slow[k], "X", 1, MSG_NOSIGNAL) < 0)
        closed_after[k] = t;
    }
  }
  for (int fd : slow) close(fd);
  std::string times;
  for (double t : closed_after) times += concat(" ", t);
  std::printf("slow clients closed after (s):%s\n", times.c_str());
  int within_deadline = 0;
  for (double t : closed_after) {
    EXPECT_GE(t, 0.0) << "a slow client was never cut";
    if (t >= 0.0 && t < 3.0) ++within_deadline;  // 1 s deadline, 100 ms ticks, a loaded machine
  }
  EXPECT_EQ(within_deadline, 24) << "closed after (s):" << times;
  // And the public port answers again.
  const auto health = server.get("/v1/health");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
}

// A run whose particle file holds bytes that are not UTF-8 fails once, as bad input: its error
// (the log's tail, which quotes the line) reaches the API as valid JSON with U+FFFD for the bad
// bytes. Before, the worker crashed while reporting it and the run went round its leases.
TEST(Service, NonUtf8BytesInARunsLogReachTheApiAsText) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 1);
  ASSERT_FALSE(server.url().empty());
  test::write_file(dir.path() / "p.txt", "# N: 1\n1 5e-4 5e-4 \xff\xfe 1e-4 0 0 0\n");
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  json study = {{"name", "bytes"}, {"scene", json::parse(in)}};
  study["scene"]["sources"] = {
      {{"type", "file"}, {"material", study["scene"]["materials"][0]["name"]}, {"path", "p.txt"}}};
  auto res = server.post("/v1/studies", study.dump());
  ASSERT_TRUE(res);
  if (res->status == 400) {  // refused at submission: the refusal itself must be JSON
    EXPECT_FALSE(json::parse(res->body, nullptr, false).is_discarded()) << res->body;
    EXPECT_NE(res->body.find("\xEF\xBF\xBD"), std::string::npos) << res->body;
    return;
  }
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["study"];
  ASSERT_FALSE(server.wait_finished(id, 60.0).is_null());
  const auto run = server.get("/v1/runs/" + id + "-r0");
  ASSERT_TRUE(run && run->status == 200);
  const json r = json::parse(run->body, nullptr, false);
  ASSERT_FALSE(r.is_discarded()) << run->body;
  EXPECT_EQ(r["state"], "EXECUTOR_ERROR");
  EXPECT_EQ(r["attempts"], 1);
  EXPECT_NE(r["error"].get<std::string>().find("\xEF\xBF\xBD"), std::string::npos) << r["error"];
}

TEST(Service, KilledWorkerLosesItsRunToAnotherAttempt) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 2, 1.0);
  ASSERT_FALSE(server.url().empty());
  auto res = server.post("/v1/studies", slow_study(2, 0.1).dump());
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["study"];
  // Wait for both runs to start, then kill one worker hard (its child dies with it).
  pid_t victim = -1;
  for (int k = 0; k < 200 && victim < 0; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    for (pid_t w : children_of(server.pid()))
      if (!children_of(w).empty() && k > 10) victim = w;
  }
  ASSERT_GT(victim, 0);
  kill(victim, SIGKILL);
  const json study = server.wait_finished(id);
  ASSERT_FALSE(study.is_null());
  EXPECT_EQ(study["progress"]["counts"]["COMPLETE"], 2);
  const json runs = json::parse(server.get("/v1/studies/" + id + "/runs")->body);
  int retried = 0;
  for (const json& r : runs["runs"]) retried += r["attempts"].get<int>() == 2;
  EXPECT_EQ(retried, 1);
}

// A lost worker's run goes to another attempt, which continues from the checkpoint the first
// left (docs/checkpoints.md) instead of from the beginning, and says so in the run's history.
TEST(Service, NextAttemptResumesFromTheLastCheckpoint) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 1, 1.0);
  ASSERT_FALSE(server.url().empty());
  json study = attrition_study({1e-4}, 6e-4);
  study["set"]["output.checkpoint_interval_s"] = 1e-4;
  auto res = server.post("/v1/studies", study.dump());
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["study"], run_id = id + "-r0";
  std::filesystem::path checkpoints;
  for (int k = 0; k < 600 && checkpoints.empty(); ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::optional<RunRecord> r = Store(dir.path() / "q.db").run(run_id);
    if (r && !r->out_dir.empty() &&
        std::filesystem::exists(std::filesystem::path(r->out_dir) / "checkpoints/"))
      for (const auto& e :
           std::filesystem::directory_iterator(std::filesystem::path(r->out_dir) / "checkpoints"))
        if (e.path().extension() == ".ckpt") checkpoints = e.path().parent_path();
  }
  ASSERT_FALSE(checkpoints.empty()) << "the run wrote no checkpoint";
  for (pid_t w : children_of(server.pid())) kill(w, SIGKILL);  // its engine child dies with it
  const json finished = server.wait_finished(id);
  ASSERT_FALSE(finished.is_null());
  EXPECT_EQ(finished["progress"]["counts"]["COMPLETE"], 1);
  const json run = json::parse(server.get("/v1/runs/" + run_id)->body);
  EXPECT_EQ(run["attempts"], 2);
  ASSERT_EQ(run["attempt_history"].size(), 2u);
  EXPECT_TRUE(run["attempt_history"][0]["resumed_from_s"].is_null());
  ASSERT_TRUE(run["attempt_history"][1]["resumed_from_s"].is_number()) << run.dump(1);
  EXPECT_GT(run["attempt_history"][1]["resumed_from_s"].get<double>(), 0.0);
  const json result = json::parse(server.get("/v1/runs/" + run_id + "/result")->body);
  EXPECT_EQ(result["status"], "ok");
  EXPECT_EQ(result["resumed"]["time_s"], run["attempt_history"][1]["resumed_from_s"]);
  EXPECT_FALSE(std::filesystem::exists(checkpoints)) << "pruned when the run completed";
}

TEST(Service, RestartedServerResumesAndCancelStopsRunningChildren) {
  test::TempDir dir;
  std::string id;
  {
    ServerProcess server(dir.path(), 2, 1.0);
    ASSERT_FALSE(server.url().empty());
    auto res = server.post("/v1/studies", slow_study(3, 0.08).dump());
    ASSERT_EQ(res->status, 201);
    id = json::parse(res->body)["study"];
    std::this_thread::sleep_for(std::chrono::milliseconds(700));  // two runs under way
  }  // stopped: SIGTERM, workers stop and their runs go back to the queue
  {
    ServerProcess server(dir.path(), 2, 1.0);
    ASSERT_FALSE(server.url().empty());
    const json study = server.wait_finished(id);
    ASSERT_FALSE(study.is_null());
    EXPECT_EQ(study["progress"]["counts"]["COMPLETE"], 3);
    Store store(dir.path() / "q.db");
    for (const RunRecord& r : store.runs(id)) EXPECT_EQ(r.state, RunState::Complete);

    // Cancel a fresh study while its runs are running.
    auto res = server.post("/v1/studies", slow_study(4, 0.3).dump());
    const std::string second = json::parse(res->body)["study"];
    std::this_thread::sleep_for(std::chrono::milliseconds(800));
    EXPECT_EQ(server.post("/v1/studies/" + second + "/cancel", "{}")->status, 200);
    const json canceled = server.wait_finished(second, 30.0);
    ASSERT_FALSE(canceled.is_null());
    EXPECT_EQ(canceled["progress"]["counts"]["CANCELED"], 4);
    EXPECT_TRUE(canceled["canceled"].get<bool>());
  }
}

TEST(Service, TwoWorkersRacingOnManyRunsRunEachOnce) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 2);
  ASSERT_FALSE(server.url().empty());
  json study = {
      {"name", "many"},
      {"scene", MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json"},
      {"parameters", {{{"path", "seed"}, {"range", {{"from", 1}, {"to", 100}, {"step", 1}}}}}}};
  // A path under the scenes root (the server runs in dir): inline instead.
  std::ifstream in(MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json");
  study["scene"] = json::parse(in);
  auto res = server.post("/v1/studies", study.dump());
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["study"];
  const json done = server.wait_finished(id);
  ASSERT_FALSE(done.is_null());
  EXPECT_EQ(done["progress"]["counts"]["COMPLETE"], 100);
  Store store(dir.path() / "q.db");
  std::set<std::string> workers;
  for (const RunRecord& r : store.runs(id)) {
    EXPECT_EQ(r.attempts, 1) << r.id;
    EXPECT_EQ(r.state, RunState::Complete);
  }
  // A run's HDF5 file downloads intact (the HDF5 signature, and the size on disk).
  auto h5 = server.get("/v1/runs/" + id + "-r7/h5");
  ASSERT_EQ(h5->status, 200);
  EXPECT_EQ(h5->body.substr(0, 8), std::string("\x89HDF\r\n\x1a\n", 8));
  EXPECT_EQ(h5->body.size(),
            std::filesystem::file_size(dir.path() / "runs" / id / (id + "-r7") / "run.h5"));
}

// `millsim regress --server`: the checks run as studies on the server's workers (a check with
// repeats as one run per seed, its row the mean of their results), the record goes to the
// server's history, and the history endpoints serve it; a malformed record is refused whole.
TEST(Service, RegressionRunsThroughTheServerAndItsHistoryIsServed) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 2);
  ASSERT_FALSE(server.url().empty());
  const json suite = {
      {"name", "nightly"},
      {"checks",
       {{{"name", "impact"},
         {"scene", MILLSIM_SOURCE_DIR "/cases/impact_two_spheres.json"},
         {"set", {{"output.h5", false}}},
         {"quantities",
          {{{"derived", "kinetic_energy_ratio"},
            {"tolerance", {{"relative", 0.01}}},
            {"reason", "e squared"}}}}},
        {{"name", "selection"},
         {"scene", MILLSIM_SOURCE_DIR "/cases/regression/breakage_probability.json"},
         {"repeats", 3},
         {"quantities",
          {{{"derived", "breakage_events"},
            {"tolerance", {{"sigmas", 4}}},
            {"reason", "binomial"}}}}}}}};
  test::write_file(dir.path() / "nightly.json", suite.dump());
  test::write_file(dir.path() / "token", std::string(kToken) + "\n");
  const std::string common = " --server " + server.url() + " --token-file token";
  test::CommandResult r =
      test::run_millsim("regress nightly.json --update-baseline" + common, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_millsim("regress nightly.json" + common, dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("nightly: PASSED"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("recorded as g000002"), std::string::npos) << r.out;

  const json list = json::parse(server.get("/v1/regressions")->body);
  ASSERT_EQ(list["regressions"].size(), 2u);
  EXPECT_EQ(list["regressions"][0]["id"], "g000002");  // newest first
  EXPECT_EQ(list["regressions"][0]["passed"], true);
  EXPECT_EQ(list["regressions"][1]["passed"], false);  // no baseline yet at the first run
  const json one = json::parse(server.get("/v1/regressions/g000002")->body);
  ASSERT_EQ(one["rows"].size(), 2u);
  EXPECT_NEAR(one["rows"][0]["measured"].get<double>(), 0.25, 0.005);
  const std::string study = one["studies"]["impact"];
  const json result = json::parse(server.get("/v1/runs/" + study + "-r0/result")->body);
  EXPECT_EQ(result["scene"], "impact_two_spheres");
  // The repeated check's row: the mean and spread of its three runs, as the server serves them.
  const json& selection = one["rows"][1];
  EXPECT_EQ(selection["repeats"], 3);
  std::vector<double> events;
  for (int i = 0; i < 3; ++i) {
    const auto res = server.get("/v1/runs/" + one["studies"]["selection"].get<std::string>() +
                                "-r" + std::to_string(i) + "/result");
    ASSERT_TRUE(res);
    const json run = json::parse(res->body);
    events.push_back(run["breakage"]["events"].get<double>());
  }
  const double mean = (events[0] + events[1] + events[2]) / 3;
  EXPECT_DOUBLE_EQ(selection["measured"].get<double>(), mean);
  EXPECT_GT(selection["measured_sd"].get<double>(), 0.0);
  EXPECT_EQ(selection["verdict"], "pass");
  EXPECT_EQ(server.get("/v1/regressions/g999999")->status, 404);
  EXPECT_EQ(server.get("/v1/regressions/..%2Fq.db")->status, 404);
  const json rows = json::parse(server.get("/v1/regressions?check=impact&limit=1")->body);
  ASSERT_EQ(rows["regressions"].size(), 1u);
  EXPECT_EQ(rows["regressions"][0]["rows"][0]["quantity"], "kinetic_energy_ratio");

  json bad = one;
  bad["rows"][0]["verdict"] = "fine";
  bad["rows"][0]["measured"] = "0.25";
  auto res = server.post("/v1/regressions", bad.dump());
  ASSERT_EQ(res->status, 400) << res->body;
  EXPECT_EQ(json::parse(res->body)["error"]["details"].size(), 2u) << res->body;
  EXPECT_EQ(server.post("/v1/regressions", one.dump(), false)->status, 401);
  EXPECT_EQ(json::parse(server.get("/v1/regressions")->body)["regressions"].size(), 2u);
  // A record is dated by the server's clock, not by what the client wrote (issue 33).
  json backdated = one;
  backdated.erase("id");
  backdated["created"] = "1999-01-01T00:00:00Z";
  backdated["created_at"] = 915148800.0;
  const double before = double(std::time(nullptr));
  res = server.post("/v1/regressions", backdated.dump());
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const json stored = json::parse(
      server.get("/v1/regressions/" + json::parse(res->body)["id"].get<std::string>())->body);
  EXPECT_GE(stored["created_at"].get<double>(), before - 1.0) << stored.dump();
  EXPECT_EQ(stored["created"].get<std::string>().rfind("1999", 0), std::string::npos);
  const json listed = json::parse(server.get("/v1/regressions?limit=1")->body)["regressions"][0];
  EXPECT_EQ(listed["created"], stored["created"]);
  EXPECT_GE(listed["created_at"].get<double>(), before - 1.0);

  r = test::run_millsim("regress --history impact/kinetic_energy_ratio --format json" + common,
                        dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json history = json::parse(r.out);
  ASSERT_EQ(history.size(), 3u);  // with the re-posted record
  EXPECT_EQ(history[0]["verdict"], "no_baseline");
  EXPECT_EQ(history[1]["verdict"], "pass");
  EXPECT_EQ(history[2]["verdict"], "pass");
}

// Operating the server by convention: one server per port and per database file, the token
// kept out of argv and printed only when generated, a request log, 405 with Allow for a wrong
// method, 409 for canceling a finished study, the spec served, and the client's exit codes.
TEST(Service, ServerStartsSafelyAndAnswersByConvention) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 1);
  ASSERT_FALSE(server.url().empty());
  const std::string port = server.url().substr(server.url().rfind(':') + 1);
  test::CommandResult r =
      test::run_millsim("serve --workers 0 --db other.db --port " + port, dir.path());
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.err.find("cannot listen on 127.0.0.1:" + port), std::string::npos) << r.err;
  r = test::run_millsim("serve --workers 0 --db q.db --port 0", dir.path());
  EXPECT_EQ(r.exit_code, 4);
  const std::string holder = "is in use by millsim serve, pid " + std::to_string(server.pid());
  EXPECT_NE(r.err.find("q.db " + holder), std::string::npos) << r.err;
  // The same file by another name (issue 33): a symlink, a hard link; and a local study on it.
  std::filesystem::create_symlink(dir.path() / "q.db", dir.path() / "alias.db");
  std::filesystem::create_hard_link(dir.path() / "q.db", dir.path() / "hard.db");
  for (const char* name : {"alias.db", "hard.db"}) {
    r = test::run_millsim(std::string("serve --workers 0 --port 0 --db ") + name, dir.path());
    EXPECT_EQ(r.exit_code, 4) << name;
    EXPECT_NE(r.err.find(holder), std::string::npos) << r.err;
  }
  test::write_file(dir.path() / "s.study.json", slow_study(1, 0.001).dump());
  r = test::run_millsim("study s.study.json --local --db alias.db", dir.path());
  EXPECT_EQ(r.exit_code, 4) << r.err;
  EXPECT_NE(r.err.find(holder), std::string::npos) << r.err;
  std::filesystem::remove(dir.path() / "alias.db");
  std::filesystem::remove(dir.path() / "hard.db");

  // The token is in no process's argv, and the server printed it only as "(given)".
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the worker has started
  const std::vector<pid_t> children = children_of(server.pid());
  ASSERT_FALSE(children.empty());
  for (pid_t p : std::vector<pid_t>{server.pid(), children[0]}) {
    std::ifstream in("/proc/" + std::to_string(p) + "/cmdline");
    std::string cmdline((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(cmdline.find(kToken), std::string::npos) << "pid " << p;
  }
  EXPECT_NE(server.output().find("token: (given)"), std::string::npos) << server.output();
  // The command line is no place for it; a file is.
  r = test::run_millsim("serve --token secret --port 0 --db third.db", dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("MILLSIM_TOKEN or --token-file"), std::string::npos) << r.err;
  r = test::run_millsim("serve --token-file missing.txt --port 0 --db third.db", dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--token-file = missing.txt"), std::string::npos) << r.err;

  httplib::Client c = client_for(server.url());
  Reply res(c.Delete("/v1/studies"), "DELETE /v1/studies");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 405);
  EXPECT_EQ(res->get_header_value("Allow"), "GET, POST");
  EXPECT_EQ(server.get("/v1/studies/s000001/cancel")->status, 405);
  EXPECT_EQ(server.get("/v1/no/such/thing")->status, 404);
  std::ifstream spec_file(MILLSIM_SOURCE_DIR "/docs/openapi.yaml");
  const std::string spec((std::istreambuf_iterator<char>(spec_file)),
                         std::istreambuf_iterator<char>());
  res = server.get("/v1/openapi.yaml");
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, spec);

  // One request, one log line: time, method, path, status, milliseconds.
  const std::regex log_line(
      "[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9:]{8}Z DELETE /v1/studies 405 [0-9]+\\.[0-9]{3} ms");
  EXPECT_TRUE(server.output_matches_within(log_line, 10.0)) << server.output();

  // A finished study cannot be canceled: 409, and the CLI exits 2.
  res = server.post("/v1/studies", slow_study(1, 0.001).dump());
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["study"];
  ASSERT_FALSE(server.wait_finished(id).is_null());
  res = server.post("/v1/studies/" + id + "/cancel", "{}");
  EXPECT_EQ(res->status, 409);
  EXPECT_EQ(json::parse(res->body)["error"]["code"], "finished");
  const std::string common = " --server " + server.url();
  // A client verb, like serve, takes no token on its command line (ps shows argv).
  r = test::run_millsim("cancel " + id + common + " --token " + kToken, dir.path());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("MILLSIM_TOKEN or --token-file"), std::string::npos) << r.err;
  test::write_file(dir.path() / "token", std::string(kToken) + "\n");
  r = test::run_millsim("cancel " + id + common + " --token-file token", dir.path());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("HTTP 409"), std::string::npos) << r.err;
  EXPECT_EQ(json::parse(server.get("/v1/studies/" + id)->body)["canceled"], false);

  // status STUDY is a table; --format json the document.
  r = test::run_millsim("status " + id + common, dir.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("study " + id + "  slow"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(id + "-r0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("COMPLETE"), std::string::npos) << r.out;
  r = test::run_millsim("status " + id + " --format json" + common, dir.path());
  EXPECT_EQ(json::parse(r.out)["id"], id);
  r = test::run_millsim("status --format csv" + common, dir.path());
  EXPECT_EQ(r.out.rfind("study,name,runs,complete", 0), 0u) << r.out;
  EXPECT_NE(r.out.find(id + ",slow,1,1,"), std::string::npos) << r.out;

  // Exit codes: a study that does not exist is bad input (2); a server that is gone, 4.
  EXPECT_EQ(test::run_millsim("results s999999" + common, dir.path()).exit_code, 2);
  server.stop();
  test::write_file(dir.path() / "study.json", slow_study(1, 0.001).dump());
  r = test::run_millsim("submit study.json" + common, dir.path());
  EXPECT_EQ(r.exit_code, 4) << r.err;
  EXPECT_NE(r.err.find("cannot reach the server"), std::string::npos) << r.err;
  EXPECT_EQ(test::run_millsim("status" + common, dir.path()).exit_code, 4);
}

// The API contract: every endpoint, with its successes and its errors, answered by a real server;
// each response is checked against docs/openapi.yaml (declared path, method and status, and the
// body against the declared schema) by tests/contract/validate_responses.py (python3-jsonschema).
TEST(Service, EveryResponseConformsToTheOpenApiSpec) {
  const char* python = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  if (std::system((std::string(python) + " -c 'import jsonschema, yaml' 2>/dev/null").c_str()) != 0)
    GTEST_SKIP() << "python3-jsonschema or python3-yaml is not installed";
  test::TempDir dir;
  ServerProcess server(dir.path(), 1);
  ASSERT_FALSE(server.url().empty());
  std::string recorded;
  auto record = [&](const std::string& method, const std::string& path, const Reply& r) {
    ASSERT_TRUE(r) << method << " " << path;
    const std::string bare = path.substr(0, path.find('?'));
    recorded +=
        json{{"method", method},
             {"path", bare},
             {"status", r->status},
             {"content_type", r->get_header_value("Content-Type")},
             {"body", r->status == 200 && bare.size() > 3 && bare.substr(bare.size() - 3) == "/h5"
                          ? std::string()
                          : r->body}}
            .dump(-1, ' ', false, json::error_handler_t::replace) +
        "\n";
  };
  auto get = [&](const std::string& path, bool auth = false) {
    auto r = server.get(path, auth);
    record("GET", path, r);
    return r;
  };
  auto post = [&](const std::string& path, const std::string& body, bool auth = true,
                  httplib::Headers h = {}) {
    auto r = server.post(path, body, auth, h);
    record("POST", path, r);
    return r;
  };

  get("/v1/health");
  get("/v1/info");
  get("/v1/openapi.yaml");
  auto r =
      post("/v1/studies", attrition_study({1e-4, 8e-5}).dump(), true, {{"Idempotency-Key", "c"}});
  ASSERT_EQ(r->status, 201) << r->body;
  const std::string id = json::parse(r->body)["study"];
  post("/v1/studies", attrition_study({1e-4, 8e-5}).dump(), true, {{"Idempotency-Key", "c"}});
  post("/v1/studies", "{not json");
  post("/v1/studies", R"({"scene": 3, "parameters": "x"})");
  post("/v1/studies", "{}", false);
  post("/v1/studies", std::string(300000, ' '));
  ASSERT_FALSE(server.wait_finished(id).is_null());
  get("/v1/studies");
  get("/v1/studies?limit=0");
  get("/v1/studies/" + id);
  get("/v1/studies/s999999");
  get("/v1/studies/" + id + "/runs");
  get("/v1/studies/" + id + "/runs?state=BOGUS");
  get("/v1/studies/" + id + "/results");
  get("/v1/studies/" + id + "/plot/error-vs-time");
  get("/v1/studies/" + id + "/plot/psd");
  post("/v1/studies/" + id + "/cancel", "{}");
  post("/v1/studies/s999999/cancel", "{}");
  get("/v1/runs/" + id + "-r0");
  get("/v1/runs/" + id + "-r0/psd");
  get("/v1/runs/" + id + "-r0/result");
  get("/v1/runs/" + id + "-r0/h5");
  get("/v1/runs/s999999-r0/result");
  // A run that is not COMPLETE: queue a slow one and read it while it runs.
  r = post("/v1/studies", slow_study(1, 0.3).dump());
  const std::string slow = json::parse(r->body)["study"];
  get("/v1/runs/" + slow + "-r0/psd");
  get("/v1/runs/" + slow + "-r0/result");
  post("/v1/studies/" + slow + "/cancel", "{}");
  ASSERT_FALSE(server.wait_finished(slow).is_null());
  get("/v1/studies/" + slow + "/plot/psd");  // no run with a PSD: 404

  const json regression = {{"suite", "s"},
                           {"passed", true},
                           {"build", json::object()},
                           {"rows", {{{"check", "c"}, {"quantity", "q"}, {"verdict", "pass"}}}}};
  r = post("/v1/regressions", regression.dump());
  EXPECT_EQ(r->status, 201);
  post("/v1/regressions", R"({"suite": "s"})");
  get("/v1/regressions");
  get("/v1/regressions?check=c");
  get("/v1/regressions/" + json::parse(r->body)["id"].get<std::string>());
  get("/v1/regressions/g999999");

  post("/v1/worker/claim", R"({"worker": "w"})");
  post("/v1/worker/claim", "[1]");
  post("/v1/worker/runs/" + id + "-r0/heartbeat", R"({"token": 999})");
  post("/v1/worker/runs/" + id + "-r0/heartbeat", "{}");
  post("/v1/worker/runs/" + id + "-r0/finish", R"({"token": 999, "state": "COMPLETE"})");
  post("/v1/worker/runs/" + id + "-r0/finish", "{}");
  httplib::Client c = client_for(server.url());
  record("DELETE", "/v1/studies", Reply(c.Delete("/v1/studies"), "DELETE /v1/studies"));
  get("/v1/nothing/here");

  test::write_file(dir.path() / "responses.jsonl", recorded);
  const std::string command = std::string(python) +
                              " " MILLSIM_SOURCE_DIR
                              "/tests/contract/validate_responses.py " MILLSIM_SOURCE_DIR
                              "/docs/openapi.yaml " +
                              (dir.path() / "responses.jsonl").string() + " > " +
                              (dir.path() / "contract.txt").string() + " 2>&1";
  const int status = std::system(command.c_str());
  std::ifstream report(dir.path() / "contract.txt");
  const std::string text((std::istreambuf_iterator<char>(report)),
                         std::istreambuf_iterator<char>());
  EXPECT_EQ(status, 0) << text;
  EXPECT_NE(text.find(" responses, 0 problems"), std::string::npos) << text;
}

// The lines of the server's request log that match `pattern`.
int count_lines(const std::string& log, const std::regex& pattern) {
  std::istringstream in(log);
  int n = 0;
  for (std::string line; std::getline(in, line);) n += std::regex_search(line, pattern) ? 1 : 0;
  return n;
}

// An idle worker asks for a run about once a second: those polls (claims answered 204) write at
// most one request-log line a minute, not one each. A claim that hands out a run and every other
// request are logged as before.
TEST(Service, IdleWorkerPollsWriteAtMostOneLogLineAMinute) {
  test::TempDir dir;
  ServerProcess server(dir.path(), 0);  // no worker of its own: only these polls claim
  ASSERT_FALSE(server.url().empty());
  const int polls = 30;
  for (int k = 0; k < polls; ++k) {
    const Reply r = server.post("/v1/worker/claim", R"({"worker": "idle"})");
    ASSERT_TRUE(r) << "no response to an idle claim";
    ASSERT_EQ(r->status, 204);
  }
  const Reply submitted = server.post("/v1/studies", slow_study(1, 0.01).dump());
  ASSERT_TRUE(submitted) << "no response to the submit";
  ASSERT_EQ(submitted->status, 201) << submitted->body;
  const Reply claim = server.post("/v1/worker/claim", R"({"worker": "busy"})");
  ASSERT_TRUE(claim) << "no response to the claim";
  ASSERT_EQ(claim->status, 200) << claim->body;
  // Lines are written after their response, each by its connection's thread: wait for the last
  // ones, and a little more for any idle poll's line still on its way.
  ASSERT_TRUE(server.output_matches_within(std::regex("POST /v1/worker/claim 200"), 30.0))
      << server.output();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const std::string log = server.output();
  EXPECT_LE(count_lines(log, std::regex("POST /v1/worker/claim 204")), 1) << log;
  EXPECT_EQ(count_lines(log, std::regex("POST /v1/worker/claim 200")), 1) << log;
  EXPECT_EQ(count_lines(log, std::regex("POST /v1/studies 201")), 1) << log;
}

// The dashboard at / in a real headless Chromium (tests/web/dashboard_check.py drives it over
// the DevTools protocol): the studies with their progress, newest first, a submit with the token
// typed into the page, a cancel refused with a wrong token (its error kept through refreshes
// until dismissed), a cancel not confirmed and one confirmed, a finished study's results and
// plots, and a run's PSD (with its axis titles) and log tail (the thermo lines). What the page
// shows is checked against the API; a study's name with markup in it stays text.
TEST(Dashboard, ChromiumShowsStudiesSubmitsAndCancels) {
  if (test::run_shell("command -v chromium >/dev/null").exit_code != 0)
    GTEST_SKIP() << "chromium is not installed (Debian chromium)";
  test::TempDir dir;
  ServerProcess server(dir.path(), 1);
  ASSERT_FALSE(server.url().empty());
  auto res = server.post("/v1/studies", attrition_study({1e-4, 8e-5}).dump());
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string finished = json::parse(res->body)["study"];
  ASSERT_FALSE(server.wait_finished(finished).is_null());
  json slow = slow_study(3, 0.5);
  slow["name"] = "slow <img src=x onerror=alert(1)>";
  test::write_file(dir.path() / "slow.json", slow.dump());

  const auto [status, out] =
      test::run_shell("python3 " MILLSIM_SOURCE_DIR "/tests/web/dashboard_check.py " +
                      server.url() + " " + kToken + " " + (dir.path() / "slow.json").string() +
                      " " + finished + " 2>&1")
          .status_and_output();
  ASSERT_EQ(status, 0) << out;
  const json seen = json::parse(out.substr(out.find('{')));

  ASSERT_EQ(seen["studies"].size(), 1u);
  EXPECT_EQ(seen["studies"][0]["id"], finished);
  EXPECT_EQ(seen["studies"][0]["complete"], "2/2");
  EXPECT_TRUE(seen["studies"][0]["bar"].get<bool>());

  // The study submitted through the page exists with its runs, and the page's cancel reached it.
  const std::string submitted = seen["submitted_hash"].get<std::string>().substr(10);
  const json api_study = json::parse(server.get("/v1/studies/" + submitted)->body);
  EXPECT_EQ(api_study["name"], slow["name"]);
  EXPECT_EQ(seen["submitted_rows"], 3);
  // A list refresh answered only after the page moved to the study does not draw over it.
  EXPECT_TRUE(seen["list_refresh_held"].get<bool>()) << "the token's change refreshed nothing";
  EXPECT_TRUE(seen["held_list_answered"].get<bool>());
  EXPECT_FALSE(seen["list_drawn_over_study"].get<bool>())
      << "a refresh that was overtaken drew the studies list over the study page";
  EXPECT_EQ(api_study["progress"]["total"], 3);
  // A refused cancel: its error stays through refreshes until dismissed; the page asked first.
  EXPECT_NE(seen["refused_notice"].get<std::string>().find("HTTP 401"), std::string::npos)
      << seen["refused_notice"];
  EXPECT_TRUE(seen["refreshed"].get<bool>()) << "the page refreshed while the error was shown";
  EXPECT_EQ(seen["refused_notice_after_refreshes"], seen["refused_notice"]);
  EXPECT_TRUE(seen["notice_dismissed"].get<bool>());
  EXPECT_NE(seen["confirm_question"].get<std::string>().find("Cancel study " + submitted),
            std::string::npos)
      << seen["confirm_question"];
  EXPECT_FALSE(seen["canceled_when_not_confirmed"].get<bool>());
  EXPECT_TRUE(seen["canceled_shown"].get<bool>());
  EXPECT_TRUE(api_study["canceled"].get<bool>());

  // The finished study's rows as the API gives them.
  const json results = json::parse(server.get("/v1/studies/" + finished + "/results")->body);
  ASSERT_EQ(seen["finished_rows"].size(), results["runs"].size());
  for (std::size_t k = 0; k < results["runs"].size(); ++k) {
    const json& row = results["runs"][k];
    EXPECT_EQ(seen["finished_rows"][k]["run"], row["run"]);
    EXPECT_EQ(seen["finished_rows"][k]["state"], "COMPLETE");
    char d50[32];
    std::snprintf(d50, sizeof d50, "%.1f", row["d50_m"].get<double>() * 1e6);
    EXPECT_EQ(seen["finished_rows"][k]["d50"], d50);
  }
  EXPECT_EQ(seen["plots"], json::array({"error against run time", "outlet PSD of every run"}));

  // A run's details: its PSD (one point per class edge) and its log.
  const std::string first_run = results["runs"][0]["run"];
  const json psd = json::parse(server.get("/v1/runs/" + first_run + "/psd")->body)["outlet_psd"];
  EXPECT_NE(seen["run_details"]["title"].get<std::string>().find(first_run), std::string::npos);
  EXPECT_EQ(seen["run_details"]["psd_points"], psd["edges_m"].size());
  // The run's impact-energy spectrum, drawn by the API, shown as a loaded image.
  EXPECT_EQ(seen["run_details"]["spectrum"], json::array({"impact-energy spectrum"}))
      << seen["run_details"];
  EXPECT_NE(seen["run_details"]["psd"].get<std::string>().find("d50"), std::string::npos);
  // The axis titles say what the plot shows: the mass finer than each edge against diameter.
  const std::set<std::string> psd_texts = seen["run_details"]["psd_texts"];
  EXPECT_TRUE(psd_texts.count("particle diameter (µm), log scale")) << seen["run_details"];
  EXPECT_TRUE(psd_texts.count("cumulative mass fraction")) << seen["run_details"];
  // The log tail is the run's thermo lines, not the end of its JSON summary.
  const std::string log_tail = seen["run_details"]["log_tail"];
  EXPECT_NE(log_tail.find("KinEng_J"), std::string::npos) << log_tail;
  EXPECT_EQ(log_tail.find('{'), std::string::npos) << log_tail;

  // The list is newest first: the study submitted through the page, then the finished one.
  ASSERT_EQ(seen["studies_after"].size(), 2u) << seen["studies_after"];
  EXPECT_EQ(seen["studies_after"][0]["id"], submitted);
  EXPECT_EQ(seen["studies_after"][1]["id"], finished);

  // Markup in a name is shown as the text it is.
  bool found = false;
  for (const json& st : seen["studies_after"])
    if (st["id"] == submitted) {
      found = true;
      EXPECT_EQ(st["name"], slow["name"]);
      EXPECT_EQ(st["markup_in_name"], 0);
      EXPECT_EQ(st["state"], "canceled");
    }
  EXPECT_TRUE(found);
  // The page's own policy: nothing loads from anywhere else.
  const auto page = server.get("/");
  ASSERT_TRUE(page && page->status == 200);
  EXPECT_NE(page->get_header_value("Content-Security-Policy").find("script-src 'self'"),
            std::string::npos);
}

}  // namespace
}  // namespace millsim
