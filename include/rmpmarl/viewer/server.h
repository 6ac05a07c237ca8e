#pragma once
/// The viewer's HTTP + WebSocket server (Boost.Beast, one I/O thread): serves the built page from memory and relays
/// messages between the pages and a viewer::Realtime loop. A page that stops reading loses frames, never stalls the
/// loop; a socket that closes or misbehaves is dropped alone.
#include <cstddef>
#include <map>
#include <memory>
#include <string>

#include "rmpmarl/viewer/realtime.h"

namespace rmpmarl::viewer {

/// Options of the server.
struct ServerOptions {
  std::string host = "127.0.0.1";  ///< address to bind (loopback unless the user opens it)
  int port = 8080;                 ///< 0: any free port (see Server::port)
  std::string web_root;            ///< directory of the built page (index.html, app.js, ...)
  std::size_t max_clients = 32;    ///< WebSocket connections at once; more are answered 503
  std::size_t max_pending_frames = 4;  ///< frames waiting for a slow page; older ones are dropped
  /// more files to serve from memory: path ("/meshes/0.bin") → body, served as application/octet-stream
  std::map<std::string, std::string> extra_files{};
};

/// Counters of the server (thread-safe reads).
struct ServerCounters {
  long connections = 0;      ///< WebSocket connections accepted so far
  long open = 0;             ///< open now
  long dropped_frames = 0;   ///< frames not sent to a page that was behind
  long http_requests = 0;
  long bad_requests = 0;     ///< HTTP requests refused (unknown path, method, oversized)
};

/// Stop the Realtime loop (and join its thread) before the Server goes: the loop's pending replies refer to it.
class Server {
 public:
  /// reads the page's files from options.web_root into memory and binds. Throws InputError when the page is not
  /// built there or the address cannot be bound (naming host and port).
  Server(ServerOptions options, Realtime& loop);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// the bound port.
  int port() const;
  /// the URL of the page.
  std::string url() const;
  /// starts the I/O thread.
  void Start();
  /// stops accepting, closes every socket and joins the I/O thread.
  void Stop();
  /// sends a message to every page (thread-safe). `droppable`: a frame that a page behind may skip.
  void Broadcast(std::shared_ptr<const std::string> message, bool droppable);
  ServerCounters counters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// the directory of the built page: `requested` when not empty, else the build tree's, else the installed one.
std::string DefaultWebRoot(const std::string& requested);

}  // namespace rmpmarl::viewer
