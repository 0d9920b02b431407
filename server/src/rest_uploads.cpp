// GET /api/v1/uploads, DELETE /api/v1/uploads/NAME, the source upload of a deleted dataset, and
// where POST /api/v1/uploads?name=FILE puts its body: streamed into uploads/.FILE.part by
// HttpSession (never held in memory), renamed to uploads/FILE when complete, so a half upload
// never appears under its name.
//
// What an upload is for comes from the jobs' records (jobs.h): a job's source names the
// upload it read, its state says whether it made a dataset or failed. A file changed after a
// job was submitted is not the file that job read, so a job only speaks for the uploads
// no newer than itself.
#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>

#include "rest.h"

namespace tetrascope::server {
namespace fs = std::filesystem;
namespace {

// A plain file's size and last change (lstat: a symlink is never followed, so never an upload).
struct FileFacts {
  bool regular = false;
  uint64_t bytes = 0;
  double modified = 0;  // unix seconds
};

FileFacts file_facts(const fs::path& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return {};
  return {true, static_cast<uint64_t>(st.st_size), static_cast<double>(st.st_mtim.tv_sec) + st.st_mtim.tv_nsec * 1e-9};
}

bool dataset_exists(const Server::Impl& server, const std::string& name) {
  std::error_code ec;
  return fs::exists(server.options.data_dir / name / "manifest.json", ec);
}

// Each existing dataset's source, from the newest job that made it (a name may have been
// deleted and made again from another file).
std::map<std::string, std::string> dataset_sources(const Server::Impl& server, const nlohmann::json& jobs) {
  std::map<std::string, std::string> sources;
  for (const auto& job : jobs)  // newest first
    if (job["state"] == "done") sources.try_emplace(job["name"].get<std::string>(), job["source"].get<std::string>());
  std::erase_if(sources, [&](const auto& entry) { return !dataset_exists(server, entry.first); });
  return sources;
}

// An upload as the listing shows it: what it is, the datasets made from it, the job reading it
// now, and the failure of the newest job that read this very file.
nlohmann::json describe_upload(const std::string& name, const FileFacts& file, const nlohmann::json& jobs, const std::map<std::string, std::string>& sources) {
  const std::string path = "uploads/" + name;
  nlohmann::json datasets = nlohmann::json::array();
  for (const auto& [dataset, source] : sources)
    if (source == path) datasets.push_back(dataset);
  nlohmann::json job = nullptr, error = nullptr, failed_job = nullptr;
  bool newest_seen = false;
  for (const auto& j : jobs) {  // newest first
    if (j["source"] != path) continue;
    if (j["state"] == "queued" || j["state"] == "running") job = j["id"];
    if (!newest_seen && j["created"].get<double>() >= file.modified) {
      newest_seen = true;
      if (j["state"] == "failed") {
        failed_job = j["id"];
        error = j["error"];
      }
    }
  }
  const bool failed = !failed_job.is_null() && datasets.empty();
  const char* state = !job.is_null() ? "reading" : !datasets.empty() ? "used" : failed ? "failed" : "unused";
  return {{"name", name}, {"path", path}, {"bytes", file.bytes}, {"modified", file.modified}, {"state", state}, {"datasets", datasets}, {"job", job},
          {"failed", failed}, {"failed_job", failed ? failed_job : nullptr}, {"error", failed ? error : nullptr}};
}

}  // namespace

Response list_uploads(const RestRequest& r) {
  const nlohmann::json jobs = r.server.jobs ? r.server.jobs->list() : nlohmann::json::array();
  const auto sources = dataset_sources(r.server, jobs);
  std::vector<nlohmann::json> uploads;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(r.server.options.data_dir / "uploads", ec)) {
    const std::string name = entry.path().filename().string();
    const FileFacts file = file_facts(entry.path());
    // a symlink is not an upload: listing it would report its target's size (a file elsewhere)
    if (file.regular && valid_name(name)) uploads.push_back(describe_upload(name, file, jobs, sources));
  }
  std::sort(uploads.begin(), uploads.end(), [](const auto& a, const auto& b) { return a["modified"].template get<double>() > b["modified"].template get<double>(); });
  return json_response(r.request, http::status::ok, {{"uploads", uploads}});
}

Response delete_upload(const RestRequest& r) {
  const std::string& name = r.tail;
  if (!valid_name(name))  // "../x", "a/b", "/etc/x" (decoded): never a path outside uploads/
    return error_response(r.request, http::status::bad_request, "bad_name",
                          "'" + name.substr(0, 128) + "' is not an upload's name: a file directly in uploads/, 1-128 letters, digits, '.', '_' or '-', not starting with '.' or '-'");
  const fs::path path = r.server.options.data_dir / "uploads" / name;
  if (!file_facts(path).regular) return error_response(r.request, http::status::not_found, "not_found", "no upload named '" + name + "'");
  std::lock_guard lock(r.server.uploads_mutex);  // held until removed: a new upload of the name renames in after
  if (r.server.uploads_in_progress.count(name))
    return error_response(r.request, http::status::conflict, "upload_in_progress", "an upload of '" + name + "' is streaming in; try again when it has finished");
  if (auto job = r.server.jobs->job_reading("uploads/" + name))
    return error_response(r.request, http::status::conflict, "in_use", "job " + *job + " reads uploads/" + name + "; cancel it or wait until it ends, then delete the upload");
  std::error_code ec;
  fs::remove(path, ec);
  if (ec) return error_response(r.request, http::status::internal_server_error, "internal", "cannot delete uploads/" + name + ": " + ec.message());
  return json_response(r.request, http::status::ok, {{"deleted", "uploads/" + name}});
}

std::optional<SourceUpload> source_upload_of(Server::Impl& server, const std::string& dataset) {
  if (!server.jobs) return std::nullopt;
  for (const auto& job : server.jobs->list()) {  // newest first: the job that made the dataset there now
    if (job["state"] != "done" || job["name"] != dataset) continue;
    const std::string source = job["source"];
    if (source.rfind("uploads/", 0) != 0 || !valid_name(source.substr(8))) return std::nullopt;
    return SourceUpload{source.substr(8), job["created"].get<double>()};
  }
  return std::nullopt;
}

std::optional<std::string> remove_source_upload(Server::Impl& server, const SourceUpload& upload) {
  const std::string path = "uploads/" + upload.name;
  const FileFacts file = file_facts(server.options.data_dir / path);
  // a file changed since the job was submitted is another mesh under the same name
  if (!file.regular || file.modified > upload.job_created) return std::nullopt;
  for (const auto& [dataset, source] : dataset_sources(server, server.jobs->list()))
    if (source == path) return std::nullopt;  // another dataset was made from it
  std::lock_guard lock(server.uploads_mutex);
  if (server.uploads_in_progress.count(upload.name) || server.jobs->job_reading(path)) return std::nullopt;
  std::error_code ec;
  return fs::remove(server.options.data_dir / path, ec) && !ec ? std::optional(path) : std::nullopt;
}

UploadPaths upload_paths(Server::Impl& server, const Target& target) {
  auto it = target.query.find("name");
  const std::string name = it == target.query.end() ? "" : it->second;
  if (!valid_name(name)) throw BadRequest(400, "bad_request", "name: 1-128 letters, digits, '.', '_' or '-', not starting with '.' or '-'");
  const fs::path folder = server.options.data_dir / "uploads";
  std::error_code ec;
  fs::create_directories(folder, ec);
  UploadPaths paths;
  paths.final_path = folder / name;
  {
    std::lock_guard lock(server.uploads_mutex);
    // a queued or running job's input stays what it was submitted with (refused before the body comes)
    if (auto job = server.jobs ? server.jobs->job_reading("uploads/" + name) : std::nullopt)
      throw BadRequest(409, "in_use", "job " + *job + " reads uploads/" + name + "; cancel it or wait until it ends before replacing it");
    if (!server.uploads_in_progress.insert(name).second)
      throw BadRequest(409, "upload_in_progress", "an upload of '" + name + "' is streaming in already; try again when it has finished");
  }
  Server::Impl* owner = &server;
  paths.claim = std::shared_ptr<void>(nullptr, [owner, name](void*) {
    std::lock_guard lock(owner->uploads_mutex);
    owner->uploads_in_progress.erase(name);
  });
  std::string temp = (folder / ("." + name + ".XXXXXX.part")).string();
  paths.temp_fd = ::mkostemps(temp.data(), 5, O_CLOEXEC);
  if (paths.temp_fd < 0) throw BadRequest(500, "internal", "cannot create the upload's temporary file: " + std::string(std::strerror(errno)));
  paths.temp_path = temp;
  return paths;
}

void sweep_stale_uploads(const fs::path& data_dir) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(data_dir / "uploads", ec)) {
    const std::string file = entry.path().filename().string();
    const bool part = file.size() > 6 && file.front() == '.' && file.ends_with(".part");
    if ((part || file.ends_with(".tmp")) && !entry.is_directory(ec)) fs::remove(entry.path(), ec);
  }
}

Response finish_upload(Server::Impl& server, ReplyTo to, const UploadPaths& paths) {
  std::error_code ec;
  const uint64_t bytes = fs::file_size(paths.temp_path, ec);
  std::lock_guard lock(server.uploads_mutex);
  const std::string name = paths.final_path.filename().string();
  // a job submitted while the body streamed in reads the file as it was
  if (auto job = server.jobs ? server.jobs->job_reading("uploads/" + name) : std::nullopt) {
    fs::remove(paths.temp_path, ec);
    return error_response(to, http::status::conflict, "in_use", "job " + *job + " reads uploads/" + name + "; cancel it or wait until it ends before replacing it");
  }
  fs::rename(paths.temp_path, paths.final_path, ec);
  if (ec) return error_response(to, http::status::internal_server_error, "internal", "cannot store the upload: " + ec.message());
  return json_response(to, http::status::created, {{"path", "uploads/" + paths.final_path.filename().string()}, {"bytes", bytes}});
}

}  // namespace tetrascope::server
