// GET /api/v1/uploads, DELETE /api/v1/uploads/NAME, and where POST /api/v1/uploads?name=FILE puts its body: streamed into
// uploads/.FILE.part by HttpSession (never held in memory), renamed to uploads/FILE when
// complete, so a half upload never appears under its name.
#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "rest.h"

namespace tetrascope::server {
namespace fs = std::filesystem;

Response list_uploads(const RestRequest& r) {
  nlohmann::json out = nlohmann::json::array();
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(r.server.options.data_dir / "uploads", ec))
    // a symlink is not an upload: listing it would report its target's size (a file elsewhere)
    if (!entry.is_symlink(ec) && entry.is_regular_file(ec) && valid_name(entry.path().filename().string()))
      out.push_back({{"path", "uploads/" + entry.path().filename().string()}, {"bytes", entry.file_size()}});
  return json_response(r.request, http::status::ok, {{"uploads", out}});
}

Response delete_upload(const RestRequest& r) {
  const std::string& name = r.tail;
  const fs::path path = r.server.options.data_dir / "uploads" / name;
  std::error_code ec;
  if (!valid_name(name) || fs::is_symlink(path, ec) || !fs::is_regular_file(path, ec))
    return error_response(r.request, http::status::not_found, "not_found", "no upload named '" + name + "'");
  std::lock_guard lock(r.server.uploads_mutex);  // held until removed: a new upload of the name renames in after
  if (r.server.uploads_in_progress.count(name))
    return error_response(r.request, http::status::conflict, "upload_in_progress", "an upload of '" + name + "' is streaming in; try again when it has finished");
  if (auto job = r.server.jobs->job_reading("uploads/" + name))
    return error_response(r.request, http::status::conflict, "in_use", "job " + *job + " reads uploads/" + name + "; cancel it or wait until it ends");
  fs::remove(path, ec);
  if (ec) return error_response(r.request, http::status::internal_server_error, "internal", "cannot delete uploads/" + name + ": " + ec.message());
  return json_response(r.request, http::status::ok, {{"deleted", "uploads/" + name}});
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
