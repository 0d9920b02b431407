#include "jobs.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <random>

#include "datasets.h"

namespace tetrascope::server {
namespace fs = std::filesystem;

struct JobRunner::Job {
  std::string id, source, name;
  nlohmann::json options = nlohmann::json::object();
  std::string state = "queued";  // queued, running, done, failed, cancelled
  std::string stage, error;
  double percent = 0, eta_s = -1, elapsed_s = 0;
  double created = 0, started = 0, finished = 0;  // unix seconds
  std::deque<std::string> log_tail;
  pid_t pid = 0;
  bool cancel_requested = false;
};

namespace {

constexpr size_t kLogTailLines = 40;
constexpr const char* kStates[] = {"queued", "running", "done", "failed", "cancelled"};

double now_s() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

std::string new_id() {
  static std::mt19937_64 random{std::random_device{}()};
  static std::mutex mutex;
  std::lock_guard lock(mutex);
  char id[40];
  std::snprintf(id, sizeof id, "j%llx%06llx", static_cast<unsigned long long>(std::time(nullptr)), static_cast<unsigned long long>(random() & 0xFFFFFF));
  return id;
}

// Options a client may pass to preprocess, and their flags.
const std::map<std::string, std::string> kOptionFlags = {{"base_tets", "--base-tets"}, {"segment_tets", "--segment-tets"}, {"level_ratio", "--level-ratio"},
                                                         {"bins", "--bins"},           {"threads", "--threads"},           {"seed", "--seed"},
                                                         {"memory_mb", "--memory-mb"}, {"variants", "--variants"}, {"model", "--model"},
                                                         {"all_steps", "--all-steps"}};

// What a job leaves while it runs: the store (out/), the writer's temporary (out.tmp/) and
// the copy it replaces (out.old/). None of them outlives the job.
void remove_job_output(const fs::path& folder) {
  std::error_code ec;
  for (const char* name : {"out", "out.tmp", "out.old"}) fs::remove_all(folder / name, ec);
}

// The command line of a job: preprocess `source` (inside data_dir) into `out` with the
// client's options, progress as JSON lines.
std::vector<std::string> preprocess_command(const fs::path& binary, const fs::path& data_dir, const std::string& source, const fs::path& out,
                                            const nlohmann::json& options) {
  std::vector<std::string> args = {binary.string(), "preprocess", (data_dir / source).string(), "-o", out.string(), "--progress", "json"};
  for (const auto& [key, value] : options.items()) {
    args.push_back(kOptionFlags.at(key));
    if (value.is_boolean()) continue;  // a switch (all_steps: kept only when true)
    args.push_back(value.is_string() ? value.get<std::string>() : value.is_number_unsigned() ? std::to_string(value.get<uint64_t>()) : value.dump());
  }
  return args;
}

// Starts `args` as a child in its own process group under the job limits, its stdout and
// stderr into a pipe whose read end is left in pipe_fds[0]. Returns the child's pid, or -1
// with the reason in failure.
pid_t start_preprocess(std::vector<std::string>& args, const JobLimits& limits, int pipe_fds[2], std::string& failure) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const rlimit memory_limit{limits.memory_bytes, limits.memory_bytes};  // prepared before fork: the child only calls setrlimit
  const rlimit cpu_limit{limits.cpu_seconds, limits.cpu_seconds + 1};   // SIGXCPU at the soft limit, SIGKILL a second later
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0) {
    failure = std::string("cannot start the job: ") + std::strerror(errno);
  } else {
    pid = ::fork();
    if (pid == 0) {  // child: only async-signal-safe calls until exec
      ::setpgid(0, 0);
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      int adj = ::open("/proc/self/oom_score_adj", O_WRONLY);  // the OOM killer picks the job, not the server
      if (adj >= 0) {
        (void)!::write(adj, "1000", 4);
        ::close(adj);
      }
      if (memory_limit.rlim_cur > 0) ::setrlimit(RLIMIT_AS, &memory_limit);
      if (cpu_limit.rlim_cur > 0) ::setrlimit(RLIMIT_CPU, &cpu_limit);
      ::dup2(pipe_fds[1], STDOUT_FILENO);
      ::dup2(pipe_fds[1], STDERR_FILENO);
      ::execv(argv[0], argv.data());
      const char message[] = "cannot run the tetrascope binary\n";
      (void)!::write(STDERR_FILENO, message, sizeof message - 1);
      ::_exit(127);
    }
    if (pid < 0) failure = std::string("cannot start the job: ") + std::strerror(errno);
    else ::setpgid(pid, pid);  // as the child does: no race with an early kill(-pid)
  }
  if (pipe_fds[1] >= 0) ::close(pipe_fds[1]);
  return pid;
}

// Waits for the child; returns why it failed (out of CPU time, killed, a non-zero exit with
// the last line it printed, out of memory), or "" when it succeeded. log_tail is read under
// mutex.
std::string wait_for_child(pid_t pid, const JobLimits& limits, std::mutex& mutex, const std::deque<std::string>& log_tail) {
  std::string failure;
  int status = 0;
  rusage usage{};
  while (::wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
  }
  const auto child_cpu_seconds = [&usage] { return uint64_t(usage.ru_utime.tv_sec) + uint64_t(usage.ru_stime.tv_sec) + 1; };
  if (WIFSIGNALED(status) && limits.cpu_seconds > 0 && (WTERMSIG(status) == SIGXCPU || WTERMSIG(status) == SIGKILL) && child_cpu_seconds() >= limits.cpu_seconds) {
    failure = "out of CPU time: the job needed more than its limit of " + std::to_string(limits.cpu_seconds) + " s (serve --job-cpu-seconds)";
  } else if (WIFSIGNALED(status)) {
    failure = "preprocess was killed by signal " + std::to_string(WTERMSIG(status)) + (WTERMSIG(status) == SIGKILL ? " (out of memory, or killed)" : "");
  } else if (WEXITSTATUS(status) != 0) {
    std::lock_guard lock(mutex);
    failure = "preprocess exited with status " + std::to_string(WEXITSTATUS(status));
    if (!log_tail.empty()) failure += ": " + log_tail.back();
    const bool out_of_memory = !log_tail.empty() && (log_tail.back().find("bad_alloc") != std::string::npos ||
                                                     log_tail.back().find("cannot allocate memory") != std::string::npos);
    if (out_of_memory && limits.memory_bytes > 0) {
      failure = "out of memory: the job needed more than its limit of " + std::to_string(limits.memory_bytes >> 20) +
                " MiB (serve --job-memory-mb)";
    }
  }
  return failure;
}

}  // namespace

uint64_t physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? static_cast<uint64_t>(pages) * static_cast<uint64_t>(page) : 0;
}

JobRunner::JobRunner(fs::path data_dir, fs::path binary, unsigned max_running, JobLimits limits)
    : data_dir_(std::move(data_dir)), jobs_dir_(data_dir_ / ".jobs"), binary_(std::move(binary)), max_running_(std::max(1u, max_running)), limits_(limits) {
  fs::create_directories(jobs_dir_);
  std::lock_guard lock(mutex_);
  load();
  schedule();
}

JobRunner::~JobRunner() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    for (auto& [id, job] : jobs_)
      if (job->state == "running" && job->pid > 0) ::kill(-job->pid, SIGKILL);
  }
  for (auto& t : threads_) t.join();
}

void JobRunner::load() {
  std::error_code ec;
  std::vector<std::shared_ptr<Job>> queued;
  for (const auto& entry : fs::directory_iterator(jobs_dir_, ec)) {
    std::ifstream in(entry.path() / "job.json");
    if (!in) continue;
    nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("id")) continue;
    // a job file is ours, but may be damaged: take what reads, skip what does not
    auto text = [&](const char* key) { return j.contains(key) && j[key].is_string() ? j[key].get<std::string>() : std::string(); };
    auto number = [&](const char* key) { return j.contains(key) && j[key].is_number() ? j[key].get<double>() : 0.0; };
    auto job = std::make_shared<Job>();
    job->id = text("id");
    if (job->id != entry.path().filename().string()) continue;
    // no job runs yet: whatever output a killed server left is stale
    remove_job_output(entry.path());
    fs::remove(entry.path() / "job.json.tmp", ec);
    job->source = text("source");
    job->name = text("name");
    if (j.contains("options") && j["options"].is_object()) job->options = j["options"];
    job->state = text("state");
    if (std::find(std::begin(kStates), std::end(kStates), job->state) == std::end(kStates)) job->state = "failed";
    job->stage = text("stage");
    job->error = text("error");
    job->percent = number("percent");
    job->elapsed_s = number("elapsed_s");
    job->created = number("created");
    job->started = number("started");
    job->finished = number("finished");
    if (j.contains("log_tail") && j["log_tail"].is_array())
      for (const auto& line : j["log_tail"])
        if (line.is_string()) job->log_tail.push_back(line.get<std::string>());
    if (job->state == "running") {
      job->state = "failed";
      job->error = "the server stopped while this job ran; submit it again";
      job->finished = now_s();
      save(*job);
    } else if (job->state == "queued") {
      queued.push_back(job);
    }
    jobs_[job->id] = job;
  }
  std::sort(queued.begin(), queued.end(), [](const auto& a, const auto& b) { return a->created < b->created; });
  for (const auto& job : queued) queue_.push_back(job->id);
}

nlohmann::json JobRunner::submit(const nlohmann::json& body) {
  if (!body.is_object()) throw BadRequest(400, "bad_request", "the body is a JSON object {source, name, options}");
  if (!body.contains("source") || !body["source"].is_string()) throw BadRequest(400, "bad_request", "source: a path inside the data folder, such as uploads/mesh.vtk");
  if (!body.contains("name") || !body["name"].is_string()) throw BadRequest(400, "bad_request", "name: the dataset's name");
  const std::string source = body["source"], name = body["name"];
  const auto path = resolve_inside(data_dir_, source);
  if (!path) throw BadRequest(403, "forbidden", "source: '" + source + "' is not inside the data folder");
  std::error_code ec;
  if (!fs::is_regular_file(*path, ec)) throw BadRequest(404, "not_found", "source: no file '" + source + "' in the data folder");
  if (!valid_name(name) || name == "uploads" || name.ends_with(".tmp"))  // DATA/*.tmp are swept at start
    throw BadRequest(400, "bad_request", "name: 1-128 letters, digits, '.', '_' or '-', not starting with '.' or '-' nor ending with '.tmp'");
  if (fs::exists(data_dir_ / name, ec)) throw BadRequest(409, "exists", "a dataset named '" + name + "' exists");
  nlohmann::json options = nlohmann::json::object();
  if (body.contains("options")) {
    if (!body["options"].is_object()) throw BadRequest(400, "bad_request", "options: an object");
    for (const auto& [key, value] : body["options"].items()) {
      if (!kOptionFlags.count(key))
        throw BadRequest(400, "bad_request", "options: unknown option '" + key + "' (model, all_steps, base_tets, segment_tets, level_ratio, bins, threads, seed, memory_mb, variants)");
      if (key == "all_steps") {  // every time step of a file that holds several (Exodus II, CGNS, Gmsh, an OpenFOAM case)
        if (!value.is_boolean()) throw BadRequest(400, "bad_request", "options.all_steps: true or false");
        if (value.get<bool>()) options[key] = true;
        continue;
      }
      if (key == "model") {  // the multiresolution model: a name, never passed on unchecked
        if (!value.is_string() || (value != "mt" && value != "binary")) throw BadRequest(400, "bad_request", "options.model: 'mt' or 'binary'");
        options[key] = value;
        continue;
      }
      const bool whole = key != "level_ratio";
      if (!value.is_number() || (whole && !value.is_number_unsigned()) || value.get<double>() <= 0 || value.get<double>() > 4e9)
        throw BadRequest(400, "bad_request", "options." + key + ": " + (whole ? "a whole number" : "a number") + " above 0");
      options[key] = value;
    }
  }
  std::lock_guard lock(mutex_);
  for (const auto& [id, job] : jobs_)
    if (job->name == name && (job->state == "queued" || job->state == "running")) throw BadRequest(409, "exists", "job " + id + " is already making '" + name + "'");
  if (queue_.size() >= limits_.max_queued) {
    throw BadRequest(429, "too_many_jobs", std::to_string(queue_.size()) + " jobs are waiting already (at most " + std::to_string(limits_.max_queued) +
                                               ", serve --max-queued-jobs); try again when one has started");
  }
  auto job = std::make_shared<Job>();
  job->id = new_id();
  // the path as resolved ("./uploads/x", "uploads//x" and "uploads/x" are one file), so the
  // checks that an upload is in use (job_reading) cannot be passed by another spelling
  job->source = path->lexically_relative(fs::weakly_canonical(data_dir_, ec)).generic_string();
  job->name = name;
  job->options = options;
  job->created = now_s();
  fs::create_directories(jobs_dir_ / job->id);
  jobs_[job->id] = job;
  queue_.push_back(job->id);
  save(*job);
  schedule();
  return to_json(*job);
}

std::optional<nlohmann::json> JobRunner::get(const std::string& id) const {
  std::lock_guard lock(mutex_);
  auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return to_json(*it->second);
}

nlohmann::json JobRunner::list() const {
  std::lock_guard lock(mutex_);
  std::vector<std::shared_ptr<Job>> all;
  for (const auto& [id, job] : jobs_) all.push_back(job);
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a->created > b->created; });
  nlohmann::json out = nlohmann::json::array();
  for (const auto& job : all) out.push_back(to_json(*job));
  return out;
}

std::optional<std::string> JobRunner::job_reading(const std::string& source) const {
  std::lock_guard lock(mutex_);
  for (const auto& [id, job] : jobs_)
    if (job->source == source && (job->state == "queued" || job->state == "running")) return id;
  return std::nullopt;
}

std::optional<nlohmann::json> JobRunner::cancel(const std::string& id) {
  std::unique_lock lock(mutex_);
  auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  Job& job = *it->second;
  if (job.state == "queued") {
    queue_.erase(std::remove(queue_.begin(), queue_.end(), id), queue_.end());
    job.state = "cancelled";
    job.finished = now_s();
    save(job);
  } else if (job.state == "running") {
    job.cancel_requested = true;
    if (job.pid > 0) ::kill(-job.pid, SIGKILL);  // the run thread reports it cancelled and cleans up
    ended_.wait_for(lock, kCancelWait, [&job] { return job.state != "running"; });
  }
  return to_json(job);
}

std::map<std::string, uint64_t> JobRunner::count_by_state() const {
  std::lock_guard lock(mutex_);
  std::map<std::string, uint64_t> counts;
  for (const char* s : kStates) counts[s] = 0;
  for (const auto& [id, job] : jobs_) ++counts[job->state];
  return counts;
}

void JobRunner::schedule() {
  while (!stopping_ && running_ < max_running_ && !queue_.empty()) {
    auto job = jobs_.at(queue_.front());
    queue_.pop_front();
    job->state = "running";
    job->started = now_s();
    ++running_;
    save(*job);
    threads_.emplace_back([this, job] { run(job); });
  }
}

void JobRunner::run(std::shared_ptr<Job> job) {
  const fs::path folder = jobs_dir_ / job->id, out = folder / "out";
  std::error_code ec;
  remove_job_output(folder);
  std::vector<std::string> args = preprocess_command(binary_, data_dir_, job->source, out, job->options);
  const std::string log_path = (folder / "log").string();
  int log_fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  int pipe_fds[2] = {-1, -1};
  std::string failure;
  const pid_t pid = start_preprocess(args, limits_, pipe_fds, failure);
  if (pid > 0) {
    {
      std::lock_guard lock(mutex_);
      job->pid = pid;
      if (stopping_ || job->cancel_requested) ::kill(-pid, SIGKILL);
    }
    std::string pending;
    char buffer[4096];
    auto last_save = std::chrono::steady_clock::now();
    for (;;) {
      const ssize_t n = ::read(pipe_fds[0], buffer, sizeof buffer);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      if (log_fd >= 0) (void)!::write(log_fd, buffer, static_cast<size_t>(n));
      pending.append(buffer, static_cast<size_t>(n));
      size_t newline;
      std::lock_guard lock(mutex_);
      while ((newline = pending.find('\n')) != std::string::npos) {
        std::string line = pending.substr(0, newline);
        pending.erase(0, newline + 1);
        nlohmann::json progress = nlohmann::json::parse(line, nullptr, false);
        if (progress.is_object() && progress.contains("stage") && progress.contains("percent")) {
          job->stage = progress.value("stage", "");
          job->percent = std::clamp(progress.value("percent", 0.0), 0.0, 99.9);
          job->eta_s = progress.value("eta_s", -1.0);
          job->elapsed_s = progress.value("elapsed_s", 0.0);
        } else if (!line.empty()) {
          job->log_tail.push_back(without_server_paths(line, data_dir_).substr(0, 500));  // no server path reaches a client
          if (job->log_tail.size() > kLogTailLines) job->log_tail.pop_front();
        }
      }
      if (std::chrono::steady_clock::now() - last_save > std::chrono::seconds(1)) {
        save(*job);
        last_save = std::chrono::steady_clock::now();
      }
    }
    failure = wait_for_child(pid, limits_, mutex_, job->log_tail);
  }
  if (pipe_fds[0] >= 0) ::close(pipe_fds[0]);
  if (log_fd >= 0) ::close(log_fd);

  std::lock_guard lock(mutex_);
  job->pid = 0;
  job->finished = now_s();
  if (job->cancel_requested) {
    job->state = "cancelled";
  } else if (stopping_ && !failure.empty()) {
    job->state = "failed";
    job->error = "the server stopped while this job ran; submit it again";
  } else if (!failure.empty()) {
    job->state = "failed";
    job->error = failure;
  } else if (fs::exists(data_dir_ / job->name, ec)) {
    job->state = "failed";
    job->error = "a dataset named '" + job->name + "' appeared while the job ran";
  } else {
    fs::rename(out, data_dir_ / job->name, ec);
    if (ec) {
      job->state = "failed";
      job->error = "cannot move the store into place: " + ec.message();
    } else {
      job->state = "done";
      job->percent = 100;
      job->eta_s = 0;
    }
  }
  remove_job_output(folder);  // after a rename, out/ is gone already; otherwise nothing is kept
  save(*job);
  --running_;
  ended_.notify_all();
  schedule();
}

void JobRunner::save(const Job& job) const {
  const fs::path folder = jobs_dir_ / job.id, temp = folder / "job.json.tmp";
  std::error_code ec;
  fs::create_directories(folder, ec);
  {
    std::ofstream out(temp, std::ios::trunc);
    out << to_json(job).dump(1) << "\n";
    if (!out) return;
  }
  fs::rename(temp, folder / "job.json", ec);
}

nlohmann::json JobRunner::to_json(const Job& job) const {
  nlohmann::json j = {{"id", job.id},           {"source", job.source},   {"name", job.name},         {"options", job.options},
                      {"state", job.state},     {"stage", job.stage},     {"percent", job.percent},   {"elapsed_s", job.elapsed_s},
                      {"created", job.created}, {"started", job.started}, {"finished", job.finished}, {"log_tail", job.log_tail}};
  j["eta_s"] = job.eta_s >= 0 ? nlohmann::json(job.eta_s) : nlohmann::json(nullptr);
  j["error"] = job.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(job.error);
  j["pid"] = job.pid > 0 ? nlohmann::json(job.pid) : nlohmann::json(nullptr);
  if (job.state == "done") j["dataset"] = job.name;
  return j;
}

}  // namespace tetrascope::server
