// The HTTP side's handlers: one free function per resource and method, each turning a request
// into a response (the Boost.Beast examples' handle_request, split by resource). The routing
// table that picks them is in http_router.cpp; the connection, upgrades and streamed uploads
// are HttpSession's (http_session.cpp). Request targets and bodies are untrusted; a handler
// answers what it cannot serve with an error response or throws BadRequest.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "http_messages.h"
#include "server_impl.h"

namespace tetrascope::server {

struct RestRequest {
  Server::Impl& server;
  const Target& target;
  const StringRequest& request;
  std::string tail;  // the path after the route's prefix (a dataset name, a job id, a file)
};

// Picks the handler for a request with a body read in full (all but uploads and WebSocket
// upgrades). Never throws: errors become JSON error responses.
Response handle_request(Server::Impl& server, const Target& target, const StringRequest& request);
// 403 read_only: what a --read-only replica answers to uploads, jobs and deletes.
Response read_only_refusal(ReplyTo to);

// rest_status.cpp
Response get_health(const RestRequest& r);
Response get_metrics(const RestRequest& r);

// rest_datasets.cpp
Response list_datasets(const RestRequest& r);
Response get_dataset(const RestRequest& r);
// Renamed aside in one step, sessions viewing it told (`dataset_deleted`), then removed with
// its source upload (remove_source_upload): 200 {deleted, sessions_closed, upload_deleted (a
// path, or null when the upload stays)}, or 404.
Response delete_dataset(const RestRequest& r);

// rest_jobs.cpp
Response list_jobs(const RestRequest& r);
Response submit_job(const RestRequest& r);
Response get_job(const RestRequest& r);
Response cancel_job(const RestRequest& r);

// rest_uploads.cpp: the listing and deletes; the upload itself streams to disk in HttpSession.
// GET /api/v1/uploads: {uploads: [{name, path, bytes, modified, state, datasets, job, failed,
// failed_job, error}]}, newest first. state: "reading" (a queued or running job reads it),
// "used" (an existing dataset was made from it), "failed" (the newest job that read this file
// failed, and no dataset was made from it) or "unused".
Response list_uploads(const RestRequest& r);
// DELETE /api/v1/uploads/NAME: 200 {deleted}; 400 bad_name for anything but a file name (a path
// never reaches the disk); 404 when there is no such upload (a symlink is none); 409 while it
// streams in or a queued or running job reads it.
Response delete_upload(const RestRequest& r);
// The upload a dataset was made from: the newest done job that made `dataset`, when its source
// is a file in uploads/.
struct SourceUpload {
  std::string name;    // the file in uploads/
  double job_created;  // unix seconds: a file changed later is not the one the job read
};
std::optional<SourceUpload> source_upload_of(Server::Impl& server, const std::string& dataset);
// Removes a deleted dataset's source upload unless it changed since its job, another dataset
// was made from it, a job reads it or an upload of it streams in. Returns its path when removed.
std::optional<std::string> remove_source_upload(Server::Impl& server, const SourceUpload& upload);
struct UploadPaths {
  std::filesystem::path final_path;  // uploads/NAME
  std::filesystem::path temp_path;   // uploads/.NAME.XXXXXX.part, unique to this request, while the body streams in
  int temp_fd = -1;                  // temp_path, created O_EXCL (mkstemps); the upload body takes it
  std::shared_ptr<void> claim;       // holds NAME in Server::Impl::uploads_in_progress until released
};
// Where POST /api/v1/uploads?name=NAME writes: claims NAME (a second upload of it while this
// one streams gets BadRequest 409, so two bodies never mix) and creates a temporary file of
// its own. Creates uploads/. Throws BadRequest for a bad name.
UploadPaths upload_paths(Server::Impl& server, const Target& target);
// Removes uploads/.*.part and uploads/*.tmp: what uploads cut off by a killed server left.
void sweep_stale_uploads(const std::filesystem::path& data_dir);
// The route class of a path, for counting error answers in /metrics: health, metrics,
// openapi, datasets, uploads, jobs, session, static.
std::string route_class(const std::string& path);
// Moves a complete upload into place: 201 {path, bytes}; 409 when a job submitted meanwhile
// reads the name (the new bytes are dropped); 500 when it cannot.
Response finish_upload(Server::Impl& server, ReplyTo to, const UploadPaths& paths);

// static_files.cpp: the web client at /, the protocol codec and schemas at /protocol/.
Response get_openapi(const RestRequest& r);
Response get_protocol_file(const RestRequest& r);
Response get_web_file(const RestRequest& r);

}  // namespace tetrascope::server
