// GET /api/v1/uploads, and where POST /api/v1/uploads?name=FILE puts its body: streamed into
// uploads/.FILE.part by HttpSession (never held in memory), renamed to uploads/FILE when
// complete, so a half upload never appears under its name.
#include "rest.h"

namespace tetrascope::server {
namespace fs = std::filesystem;

Response list_uploads(const RestRequest& r) {
  nlohmann::json out = nlohmann::json::array();
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(r.server.options.data_dir / "uploads", ec))
    if (entry.is_regular_file() && valid_name(entry.path().filename().string()))
      out.push_back({{"path", "uploads/" + entry.path().filename().string()}, {"bytes", entry.file_size()}});
  return json_response(r.request, http::status::ok, {{"uploads", out}});
}

UploadPaths upload_paths(const Server::Impl& server, const Target& target) {
  auto it = target.query.find("name");
  const std::string name = it == target.query.end() ? "" : it->second;
  if (!valid_name(name)) throw BadRequest(400, "bad_request", "name: 1-128 letters, digits, '.', '_' or '-', not starting with '.'");
  const fs::path folder = server.options.data_dir / "uploads";
  std::error_code ec;
  fs::create_directories(folder, ec);
  return {folder / name, folder / ("." + name + ".part")};
}

Response finish_upload(ReplyTo to, const UploadPaths& paths) {
  std::error_code ec;
  const uint64_t bytes = fs::file_size(paths.temp_path, ec);
  fs::rename(paths.temp_path, paths.final_path, ec);
  if (ec) return error_response(to, http::status::internal_server_error, "internal", "cannot store the upload: " + ec.message());
  return json_response(to, http::status::created, {{"path", "uploads/" + paths.final_path.filename().string()}, {"bytes", bytes}});
}

}  // namespace tetrascope::server
