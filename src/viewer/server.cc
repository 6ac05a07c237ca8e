#include "rmpmarl/viewer/server.h"

#include <fmt/format.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <atomic>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "rmpmarl/common/error.h"

namespace rmpmarl::viewer {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

namespace {

constexpr std::size_t kMaxFileBytes = std::size_t{32} << 20;
constexpr int kMaxFiles = 256;
constexpr std::size_t kMaxQueuedReplies = 64;

std::string ContentType(const std::filesystem::path& p) {
  const std::string ext = p.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".json" || ext == ".map") return "application/json";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".ico") return "image/x-icon";
  if (ext == ".woff2") return "font/woff2";
  return "application/octet-stream";
}

struct File {
  std::string content_type;
  std::string body;
};

}  // namespace

struct Server::Impl {
  class WsSession;
  class HttpSession;

  ServerOptions options;
  Realtime& loop;
  std::map<std::string, File> files;  // request path → file, read at start, never changed after
  // declared first, destroyed last: destroying it destroys the handlers still queued (and the sessions they hold)
  // while the acceptor and the session sets below are gone already
  asio::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  asio::steady_timer accept_retry{ioc};
  std::thread thread;
  std::atomic<bool> stopped{false};
  std::atomic<bool> finished{false};  // the I/O thread's run() returned
  int port = 0;
  // the I/O thread's alone
  long next_session_id = 0;
  std::set<std::shared_ptr<WsSession>> sessions;
  std::vector<std::weak_ptr<HttpSession>> http_sessions;
  mutable std::mutex counters_mutex;
  ServerCounters counters;

  Impl(ServerOptions o, Realtime& l) : options(std::move(o)), loop(l) {}

  void Count(long ServerCounters::*field, long delta = 1) {
    std::lock_guard lock(counters_mutex);
    counters.*field += delta;
  }

  void LoadFiles() {
    namespace fs = std::filesystem;
    const fs::path root(options.web_root);
    std::error_code ec;
    if (!fs::is_regular_file(root / "index.html", ec)) {
      throw InputError(fmt::format("viewer: the page is not built in '{}' (no index.html): build it with `cmake "
                                   "--build build --target web` (needs nodejs and npm), or point --web-root at it",
                                   options.web_root));
    }
    for (auto it = fs::recursive_directory_iterator(root, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
      if (it.depth() > 2 || !it->is_regular_file()) continue;
      if (static_cast<int>(files.size()) >= kMaxFiles) {
        throw InputError(fmt::format("viewer: '{}' holds more than {} files; is it the built page?", options.web_root,
                                     kMaxFiles));
      }
      if (it->file_size() > kMaxFileBytes) {
        throw InputError(fmt::format("viewer: '{}' is larger than {} bytes", it->path().string(), kMaxFileBytes));
      }
      std::ifstream in(it->path(), std::ios::binary);
      std::ostringstream body;
      body << in.rdbuf();
      const std::string key = "/" + fs::relative(it->path(), root).generic_string();
      files[key] = File{ContentType(it->path()), body.str()};
    }
    if (ec) throw InputError(fmt::format("viewer: cannot read '{}': {}", options.web_root, ec.message()));
    files["/"] = files["/index.html"];
    for (const auto& [path, body] : options.extra_files) {
      RMPMARL_ASSERT(!path.empty() && path[0] == '/', "ServerOptions::extra_files: paths start with '/'");
      files[path] = File{"application/octet-stream", body};
    }
  }

  void Bind() {
    beast::error_code ec;
    const auto address = asio::ip::make_address(options.host, ec);
    if (ec) throw InputError(fmt::format("viewer: --host '{}' is not an IP address ({})", options.host, ec.message()));
    if (options.port < 0 || options.port > 65535) {
      throw InputError(fmt::format("viewer: --port must be in [0, 65535], got {}", options.port));
    }
    const tcp::endpoint endpoint(address, static_cast<unsigned short>(options.port));
    acceptor.open(endpoint.protocol(), ec);
    if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor.bind(endpoint, ec);
    if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) {
      throw InputError(fmt::format("viewer: cannot listen on {}:{}: {}{}", options.host, options.port, ec.message(),
                                   ec == asio::error::address_in_use ? " (choose another --port, or 0 for any)" : ""));
    }
    port = acceptor.local_endpoint().port();
  }

  // on the I/O thread: closes the acceptor and every connection, so that run() returns
  void CloseAll();

  void Accept();

  void Broadcast(const std::shared_ptr<const std::string>& message, bool droppable);
};

namespace {
constexpr std::size_t kMaxHttpSessions = 64;
}

// One WebSocket page.
class Server::Impl::WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(Impl* server, tcp::socket&& socket, long id) : server_(server), ws_(std::move(socket)), id_(id) {}

  void Run(http::request<http::string_body> request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(kMaxMessageBytes);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& r) { r.set(http::field::server, "rmpmarl-view"); }));
    ws_.async_accept(request, [self = shared_from_this()](beast::error_code ec) { self->OnAccept(ec); });
  }

  // on the I/O thread
  void Send(std::shared_ptr<const std::string> message, bool droppable) {
    if (closed_) return;
    if (droppable) {
      // a page behind: the oldest waiting frame makes room (not the one being written)
      std::size_t frames = 0;
      for (const auto& q : queue_) frames += q.droppable ? 1 : 0;
      if (frames >= server_->options.max_pending_frames) {
        for (auto it = queue_.begin() + (writing_ ? 1 : 0); it != queue_.end(); ++it) {
          if (it->droppable) {
            queue_.erase(it);
            break;
          }
        }
        server_->Count(&ServerCounters::dropped_frames);
      }
    } else if (queue_.size() >= kMaxQueuedReplies + server_->options.max_pending_frames) {
      Close();  // a page that reads nothing at all
      return;
    }
    queue_.push_back({std::move(message), droppable});
    if (!writing_) Write();
  }

  void Close() {
    if (closed_) return;
    closed_ = true;
    // the message being written stays alive until its handler runs
    if (writing_) {
      queue_.erase(queue_.begin() + 1, queue_.end());
    } else {
      queue_.clear();
    }
    if (registered_) {
      server_->sessions.erase(shared_from_this());
      server_->Count(&ServerCounters::open, -1);
    }
    beast::error_code ec;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ec);
    beast::get_lowest_layer(ws_).close();
  }

 private:
  struct Out {
    std::shared_ptr<const std::string> message;
    bool droppable = false;
  };

  void OnAccept(beast::error_code ec) {
    if (ec || server_->stopped) {
      Close();
      return;
    }
    if (server_->sessions.size() >= server_->options.max_clients) {
      // several upgrades passed the check at once: the limit holds here
      server_->Count(&ServerCounters::bad_requests);
      Close();
      return;
    }
    server_->sessions.insert(shared_from_this());
    registered_ = true;
    server_->Count(&ServerCounters::connections);
    server_->Count(&ServerCounters::open);
    Send(server_->loop.hello(), false);
    Read();
  }

  void Read() {
    ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnRead(ec); });
  }

  void OnRead(beast::error_code ec) {
    if (ec) {
      if (ec == websocket::error::message_too_big) {
        server_->loop.Refuse(fmt::format("message larger than {} bytes: connection closed", kMaxMessageBytes), {});
      }
      Close();
      return;
    }
    std::weak_ptr<WsSession> weak = shared_from_this();
    asio::io_context* ioc = &server_->ioc;
    Reply reply = [weak, ioc](std::shared_ptr<const std::string> message) {
      asio::post(*ioc, [weak, message = std::move(message)] {
        if (auto self = weak.lock()) self->Send(message, false);
      });
    };
    if (!ws_.got_text()) {
      buffer_.consume(buffer_.size());
      server_->loop.Refuse("binary message: the viewer takes JSON text messages", reply);
      Read();
      return;
    }
    std::string text = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    server_->loop.Submit(std::move(text), std::move(reply), id_);
    Read();
  }

  void Write() {
    writing_ = true;
    ws_.text(true);
    ws_.async_write(asio::buffer(*queue_.front().message),
                    [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnWrite(ec); });
  }

  void OnWrite(beast::error_code ec) {
    writing_ = false;
    if (!queue_.empty()) queue_.pop_front();
    if (ec) {
      Close();
      return;
    }
    if (closed_) return;
    if (!queue_.empty()) Write();
  }

  Impl* server_;  // outlives every session: the Server's io_context, which holds their handlers, goes last
  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  std::deque<Out> queue_;
  bool writing_ = false;
  bool closed_ = false;
  bool registered_ = false;
  long id_ = 0;  // the page, for its share of the loop's queue
};

// One HTTP connection: files, or the upgrade to a WebSocket at /ws.
class Server::Impl::HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(Impl* server, tcp::socket&& socket) : server_(server), stream_(std::move(socket)) {}

  void Run() { Read(); }

  void Close() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    stream_.close();
  }

 private:
  void Read() {
    parser_.emplace();
    parser_->header_limit(8 * 1024);
    parser_->body_limit(16 * 1024);
    stream_.expires_after(std::chrono::seconds(30));
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnRead(ec); });
  }

  void OnRead(beast::error_code ec) {
    if (ec == http::error::end_of_stream || ec == beast::error::timeout || ec == asio::error::operation_aborted ||
        server_->stopped) {
      Shutdown();
      return;
    }
    if (ec) {
      server_->Count(&ServerCounters::bad_requests);
      RespondText(http::status::bad_request, fmt::format("bad request: {}\n", ec.message()), false);
      return;
    }
    http::request<http::string_body> request = parser_->release();
    server_->Count(&ServerCounters::http_requests);
    if (websocket::is_upgrade(request)) {
      if (request.target() != "/ws") {
        server_->Count(&ServerCounters::bad_requests);
        RespondText(http::status::not_found, "the WebSocket is at /ws\n", false);
        return;
      }
      if (server_->sessions.size() >= server_->options.max_clients) {
        server_->Count(&ServerCounters::bad_requests);
        RespondText(http::status::service_unavailable,
                    fmt::format("{} pages are watching already, the most this viewer serves\n",
                                server_->options.max_clients),
                    false);
        return;
      }
      stream_.expires_never();
      std::make_shared<WsSession>(server_, stream_.release_socket(), ++server_->next_session_id)
          ->Run(std::move(request));
      return;
    }
    if (request.method() != http::verb::get && request.method() != http::verb::head) {
      server_->Count(&ServerCounters::bad_requests);
      RespondText(http::status::method_not_allowed, "only GET and HEAD\n", request.keep_alive());
      return;
    }
    std::string target(request.target());
    if (const auto q = target.find('?'); q != std::string::npos) target.resize(q);
    const auto it = server_->files.find(target);
    if (it == server_->files.end()) {
      server_->Count(&ServerCounters::bad_requests);
      RespondText(http::status::not_found, "not found\n", request.keep_alive());
      return;
    }
    // the body is the server's own copy of the file (never changed after start): not copied per request
    auto response = std::make_shared<http::response<http::span_body<const char>>>(http::status::ok, 11);
    const std::string& body = it->second.body;
    response->set(http::field::content_type, it->second.content_type);
    if (request.method() == http::verb::get) response->body() = {body.data(), body.size()};
    response->content_length(body.size());
    Send(response, request.keep_alive());
  }

  void RespondText(http::status status, std::string body, bool keep_alive) {
    auto response = std::make_shared<http::response<http::string_body>>(status, 11);
    response->set(http::field::content_type, "text/plain");
    response->body() = std::move(body);
    response->prepare_payload();
    Send(response, keep_alive);
  }

  template <typename Response>
  void Send(std::shared_ptr<Response> response, bool keep_alive) {
    response->set(http::field::server, "rmpmarl-view");
    response->set(http::field::cache_control, "no-cache");
    response->set("X-Content-Type-Options", "nosniff");
    response->keep_alive(keep_alive);
    stream_.expires_after(std::chrono::seconds(60));  // a slow download of a large file still ends
    http::async_write(stream_, *response,
                      [self = shared_from_this(), response, keep_alive](beast::error_code ec, std::size_t) {
                        if (ec || !keep_alive || self->server_->stopped) {
                          self->Shutdown();
                          return;
                        }
                        self->Read();
                      });
  }

  void Shutdown() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  Impl* server_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

void Server::Impl::Accept() {
  // one I/O thread: every handler runs on it, no strand needed
  acceptor.async_accept(ioc, [this](beast::error_code ec, tcp::socket s) {
    if (stopped || ec == asio::error::operation_aborted) return;
    if (ec) {
      // e.g. out of file descriptors: try again shortly instead of spinning on the waiting connection
      accept_retry.expires_after(std::chrono::milliseconds(100));
      accept_retry.async_wait([this](beast::error_code wait_ec) {
        if (!wait_ec && !stopped) Accept();
      });
      return;
    }
    std::erase_if(http_sessions, [](const std::weak_ptr<HttpSession>& w) { return w.expired(); });
    if (http_sessions.size() >= kMaxHttpSessions) {
      Count(&ServerCounters::bad_requests);  // too many connections at once: this one is closed
      beast::error_code ignored;
      s.close(ignored);
    } else {
      beast::error_code ignored;
      s.set_option(tcp::no_delay(true), ignored);  // frames and replies go out at once, not after Nagle's delay
      auto session = std::make_shared<HttpSession>(this, std::move(s));
      http_sessions.push_back(session);
      session->Run();
    }
    Accept();
  });
}

void Server::Impl::CloseAll() {
  beast::error_code ec;
  acceptor.close(ec);
  accept_retry.cancel();
  const std::vector<std::shared_ptr<WsSession>> ws(sessions.begin(), sessions.end());
  for (const auto& s : ws) s->Close();
  for (const auto& w : http_sessions) {
    if (auto s = w.lock()) s->Close();
  }
  http_sessions.clear();
}

void Server::Impl::Broadcast(const std::shared_ptr<const std::string>& message, bool droppable) {
  asio::post(ioc, [this, message, droppable] {
    // copy: Send may close (and erase) a session
    const std::vector<std::shared_ptr<WsSession>> copy(sessions.begin(), sessions.end());
    for (const auto& s : copy) s->Send(message, droppable);
  });
}

Server::Server(ServerOptions options, Realtime& loop) : impl_(std::make_unique<Impl>(std::move(options), loop)) {
  impl_->LoadFiles();
  impl_->Bind();
}

Server::~Server() { Stop(); }

int Server::port() const { return impl_->port; }

std::string Server::url() const {
  const std::string& host = impl_->options.host;
  const bool any = host == "0.0.0.0" || host == "::";
  const bool v6 = host.find(':') != std::string::npos;
  return fmt::format("http://{}:{}/", any ? "127.0.0.1" : (v6 ? "[" + host + "]" : host), port());
}

void Server::Start() {
  impl_->Accept();
  impl_->thread = std::thread([impl = impl_.get()] {
    try {
      impl->ioc.run();
    } catch (const std::exception& e) {
      fmt::print(stderr, "rmpmarl view: the server stopped on an error: {}\n", e.what());
    }
    impl->finished = true;
  });
}

void Server::Stop() {
  if (impl_->stopped.exchange(true)) return;
  if (!impl_->thread.joinable()) {
    beast::error_code ec;
    impl_->acceptor.close(ec);
    return;
  }
  asio::post(impl_->ioc, [impl = impl_.get()] { impl->CloseAll(); });
  // every connection closed, run() returns when the last handler has run; a handler still waiting on a timer
  // after 2 s is cut short (the io_context destroys it with the Server)
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (!impl_->finished && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!impl_->finished) impl_->ioc.stop();
  impl_->thread.join();
}

void Server::Broadcast(std::shared_ptr<const std::string> message, bool droppable) {
  if (impl_->stopped) return;
  impl_->Broadcast(message, droppable);
}

ServerCounters Server::counters() const {
  std::lock_guard lock(impl_->counters_mutex);
  return impl_->counters;
}

std::string DefaultWebRoot(const std::string& requested) {
  if (!requested.empty()) return requested;
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const char* dir : {RMPMARL_WEB_DIR, RMPMARL_INSTALLED_WEB_DIR}) {
    if (fs::is_regular_file(fs::path(dir) / "index.html", ec)) return dir;
  }
  return RMPMARL_WEB_DIR;
}

}  // namespace rmpmarl::viewer
