#include "rmpmarl/viewer/server.h"

#include <fmt/format.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
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

struct Server::Impl : std::enable_shared_from_this<Server::Impl> {
  class WsSession;
  class HttpSession;

  ServerOptions options;
  Realtime& loop;
  std::map<std::string, File> files;  // request path → file, read at start
  asio::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  std::thread thread;
  std::set<std::shared_ptr<WsSession>> sessions;  // I/O thread only
  mutable std::mutex counters_mutex;
  ServerCounters counters;
  bool stopped = false;

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
  }

  void Accept();

  void Broadcast(const std::shared_ptr<const std::string>& message, bool droppable);
};

// One WebSocket page.
class Server::Impl::WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(std::shared_ptr<Impl> server, tcp::socket&& socket)
      : server_(std::move(server)), ws_(std::move(socket)) {}

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
      std::size_t frames = 0;
      for (const auto& q : queue_) frames += q.droppable ? 1 : 0;
      if (frames >= server_->options.max_pending_frames) {
        server_->Count(&ServerCounters::dropped_frames);
        return;
      }
    } else if (queue_.size() >= kMaxQueuedReplies + server_->options.max_pending_frames) {
      Close();  // a page that reads nothing at all
      return;
    }
    queue_.push_back({std::move(message), droppable});
    if (queue_.size() == 1) Write();
  }

  void Close() {
    if (closed_) return;
    closed_ = true;
    queue_.clear();
    server_->sessions.erase(shared_from_this());
    server_->Count(&ServerCounters::open, -1);
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
    if (ec) return;  // a failed handshake: nothing was registered
    if (server_->stopped) return;
    server_->sessions.insert(shared_from_this());
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
    server_->loop.Submit(std::move(text), std::move(reply));
    Read();
  }

  void Write() {
    ws_.text(true);
    ws_.async_write(asio::buffer(*queue_.front().message),
                    [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnWrite(ec); });
  }

  void OnWrite(beast::error_code ec) {
    if (ec) {
      Close();
      return;
    }
    if (closed_) return;
    queue_.pop_front();
    if (!queue_.empty()) Write();
  }

  std::shared_ptr<Impl> server_;
  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  std::deque<Out> queue_;
  bool closed_ = false;
};

// One HTTP connection: files, or the upgrade to a WebSocket at /ws.
class Server::Impl::HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(std::shared_ptr<Impl> server, tcp::socket&& socket)
      : server_(std::move(server)), stream_(std::move(socket)) {}

  void Run() { Read(); }

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
    if (ec == http::error::end_of_stream || ec == beast::error::timeout || ec == asio::error::operation_aborted) {
      Shutdown();
      return;
    }
    if (ec) {
      server_->Count(&ServerCounters::bad_requests);
      Respond(http::status::bad_request, "text/plain", fmt::format("bad request: {}\n", ec.message()), false);
      return;
    }
    http::request<http::string_body> request = parser_->release();
    server_->Count(&ServerCounters::http_requests);
    if (websocket::is_upgrade(request)) {
      if (request.target() != "/ws") {
        server_->Count(&ServerCounters::bad_requests);
        Respond(http::status::not_found, "text/plain", "the WebSocket is at /ws\n", false);
        return;
      }
      if (server_->sessions.size() >= server_->options.max_clients) {
        server_->Count(&ServerCounters::bad_requests);
        Respond(http::status::service_unavailable, "text/plain",
                fmt::format("{} pages are watching already, the most this viewer serves\n",
                            server_->options.max_clients),
                false);
        return;
      }
      stream_.expires_never();
      std::make_shared<WsSession>(server_, stream_.release_socket())->Run(std::move(request));
      return;
    }
    if (request.method() != http::verb::get && request.method() != http::verb::head) {
      server_->Count(&ServerCounters::bad_requests);
      Respond(http::status::method_not_allowed, "text/plain", "only GET and HEAD\n", request.keep_alive());
      return;
    }
    std::string target(request.target());
    if (const auto q = target.find('?'); q != std::string::npos) target.resize(q);
    const auto it = server_->files.find(target);
    if (it == server_->files.end()) {
      server_->Count(&ServerCounters::bad_requests);
      Respond(http::status::not_found, "text/plain", "not found\n", request.keep_alive());
      return;
    }
    Respond(http::status::ok, it->second.content_type,
            request.method() == http::verb::head ? std::string() : it->second.body, request.keep_alive(),
            it->second.body.size());
  }

  void Respond(http::status status, const std::string& type, std::string body, bool keep_alive,
               std::size_t content_length = std::string::npos) {
    auto response = std::make_shared<http::response<http::string_body>>(status, 11);
    response->set(http::field::server, "rmpmarl-view");
    response->set(http::field::content_type, type);
    response->set(http::field::cache_control, "no-cache");
    response->set("X-Content-Type-Options", "nosniff");
    response->keep_alive(keep_alive);
    const std::size_t length = content_length == std::string::npos ? body.size() : content_length;
    response->body() = std::move(body);
    response->content_length(length);
    http::async_write(stream_, *response,
                      [self = shared_from_this(), response, keep_alive](beast::error_code ec, std::size_t) {
                        if (ec || !keep_alive) {
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

  std::shared_ptr<Impl> server_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

void Server::Impl::Accept() {
  // one I/O thread: every handler runs on it, no strand needed
  acceptor.async_accept(ioc, [self = shared_from_this()](beast::error_code ec, tcp::socket s) {
    if (ec) {
      if (ec == asio::error::operation_aborted || self->stopped) return;
    } else {
      beast::error_code ignored;
      s.set_option(tcp::no_delay(true), ignored);  // frames and replies go out at once, not after Nagle's delay
      std::make_shared<HttpSession>(self, std::move(s))->Run();
    }
    self->Accept();
  });
}

void Server::Impl::Broadcast(const std::shared_ptr<const std::string>& message, bool droppable) {
  asio::post(ioc, [self = shared_from_this(), message, droppable] {
    // copy: Send may close (and erase) a session
    const std::vector<std::shared_ptr<WsSession>> sessions(self->sessions.begin(), self->sessions.end());
    for (const auto& s : sessions) s->Send(message, droppable);
  });
}

Server::Server(ServerOptions options, Realtime& loop) : impl_(std::make_shared<Impl>(std::move(options), loop)) {
  impl_->LoadFiles();
  impl_->Bind();
}

Server::~Server() { Stop(); }

int Server::port() const { return impl_->acceptor.local_endpoint().port(); }

std::string Server::url() const {
  const std::string& host = impl_->options.host;
  const bool any = host == "0.0.0.0" || host == "::";
  const bool v6 = host.find(':') != std::string::npos;
  return fmt::format("http://{}:{}/", any ? "127.0.0.1" : (v6 ? "[" + host + "]" : host), port());
}

void Server::Start() {
  impl_->Accept();
  impl_->thread = std::thread([impl = impl_] { impl->ioc.run(); });
}

void Server::Stop() {
  if (!impl_ || impl_->stopped) return;
  asio::post(impl_->ioc, [impl = impl_] {
    impl->stopped = true;
    beast::error_code ec;
    impl->acceptor.close(ec);
    const std::vector<std::shared_ptr<Impl::WsSession>> sessions(impl->sessions.begin(), impl->sessions.end());
    for (const auto& s : sessions) s->Close();
  });
  if (impl_->thread.joinable()) {
    // the sessions' last handlers finish; then the context runs out of work or is stopped
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    impl_->ioc.stop();
    impl_->thread.join();
  }
  impl_->stopped = true;
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
