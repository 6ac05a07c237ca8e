// The viewer's server over real sockets on loopback: the page's files and nothing else, WebSocket pages that watch
// and steer one simulation, and messages that must not hurt it.
#include "rmpmarl/viewer/server.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/viewer/live_sim.h"

namespace rmpmarl::viewer {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using nlohmann::json;

class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = std::filesystem::temp_directory_path() / fmt::format("rmpmarl-view-test-{}", ::getpid());
    std::filesystem::create_directories(root_);
    std::ofstream(root_ / "index.html") << "<html>the page</html>";
    std::ofstream(root_ / "app.js") << "console.log(1)";
    sim_ = std::make_unique<LiveSim>(kinematics::LoadShippedRobot("panda"), nullptr, "",
                                     LiveSimOptions{.controller = "rmpflow"});
    RealtimeOptions loop_options;
    loop_options.log_refusals = false;
    loop_ = std::make_unique<Realtime>(
        *sim_, loop_options, [this](auto m) { server_->Broadcast(std::move(m), true); },
        [this](auto m) { server_->Broadcast(std::move(m), false); });
    ServerOptions options;
    options.port = 0;
    options.web_root = root_.string();
    server_ = std::make_unique<Server>(options, *loop_);
    server_->Start();
    thread_ = std::thread([this] { loop_->Run(); });
  }
  void TearDown() override {
    loop_->Stop();
    thread_.join();
    server_->Stop();
    std::filesystem::remove_all(root_);
  }

  http::response<http::string_body> Request(http::verb verb, const std::string& target) {
    asio::io_context ioc;
    beast::tcp_stream stream(ioc);
    stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server_->port()));
    http::request<http::string_body> req(verb, target, 11);
    req.set(http::field::host, "127.0.0.1");
    http::write(stream, req);
    beast::flat_buffer buffer;
    http::response_parser<http::string_body> parser;
    parser.skip(verb == http::verb::head);  // a HEAD response announces a body it does not send
    http::read(stream, buffer, parser);
    return parser.release();
  }

  struct Page {
    asio::io_context ioc;
    websocket::stream<tcp::socket> ws{ioc};
    beast::flat_buffer buffer;
    json Next() {
      buffer.consume(buffer.size());
      ws.read(buffer);
      return json::parse(beast::buffers_to_string(buffer.data()));
    }
    // the next message of `type`
    json NextOf(const std::string& type) {
      for (int n = 0; n < 1000; ++n) {
        json m = Next();
        if (m["type"] == type) return m;
      }
      throw std::runtime_error("no " + type);
    }
    void Send(const std::string& text) { ws.write(asio::buffer(text)); }
  };

  std::unique_ptr<Page> Connect() {
    auto page = std::make_unique<Page>();
    page->ws.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server_->port()));
    page->ws.handshake("127.0.0.1", "/ws");
    return page;
  }

  std::filesystem::path root_;
  std::unique_ptr<LiveSim> sim_;
  std::unique_ptr<Realtime> loop_;
  std::unique_ptr<Server> server_;
  std::thread thread_;
};

TEST_F(ServerTest, ServesThePageFilesAndNothingElse) {
  auto res = Request(http::verb::get, "/");
  EXPECT_EQ(res.result(), http::status::ok);
  EXPECT_EQ(res.body(), "<html>the page</html>");
  res = Request(http::verb::get, "/app.js?v=3");
  EXPECT_EQ(res.result(), http::status::ok);
  EXPECT_EQ(res[http::field::content_type], "text/javascript; charset=utf-8");
  for (const char* target : {"/../CMakeLists.txt", "/%2e%2e/%2e%2e/etc/passwd", "/etc/passwd", "/index.html/..",
                             "//index.html", "/ws"}) {
    EXPECT_EQ(Request(http::verb::get, target).result(), http::status::not_found) << target;
  }
  EXPECT_EQ(Request(http::verb::post, "/").result(), http::status::method_not_allowed);
  EXPECT_EQ(Request(http::verb::head, "/").result(), http::status::ok);
  EXPECT_GE(server_->counters().bad_requests, 7);
}

TEST_F(ServerTest, PagesWatchAndSteerOneSimulation) {
  auto a = Connect();
  auto b = Connect();
  const json hello = a->Next();
  ASSERT_EQ(hello["type"], "hello");
  EXPECT_EQ(hello["robot"]["name"], "panda");
  EXPECT_EQ(b->Next()["type"], "hello");
  const json f1 = a->NextOf("frame");
  a->Send(R"({"type":"set_target","p":[0.45,0.1,0.45]})");
  // both pages see the held target
  for (Page* p : {a.get(), b.get()}) {
    for (int n = 0;; ++n) {
      ASSERT_LT(n, 200) << "the target never became held";
      const json f = p->NextOf("frame");
      if (f["target"]["held"].get<bool>()) {
        EXPECT_NEAR(f["target"]["p"][0].get<double>(), 0.45, 1e-9);
        break;
      }
    }
  }
  const json f2 = b->NextOf("frame");
  EXPECT_GT(f2["t"].get<double>(), f1["t"].get<double>());
  // a refused message is answered to its sender only and counted in every frame
  a->Send("not json");
  const json error = a->NextOf("error");
  EXPECT_NE(error["message"].get<std::string>().find("not JSON"), std::string::npos);
  for (int n = 0;; ++n) {
    ASSERT_LT(n, 200);
    if (b->NextOf("frame")["refused"].get<long>() >= 1) break;
  }
  // switching the controller re-sends the hello to every page
  a->Send(R"({"type":"side_by_side","on":true})");
  EXPECT_NE(a->NextOf("error")["message"].get<std::string>().find("needs a learned controller"), std::string::npos);
  EXPECT_EQ(loop_->counters().refused.load(), 2);
}

TEST_F(ServerTest, MisbehavingSocketsAreDroppedAloneAndTheSimulationGoesOn) {
  auto watcher = Connect();
  watcher->NextOf("frame");
  {
    auto big = Connect();
    beast::error_code ec;
    const std::string huge(40000, 'x');
    big->ws.write(asio::buffer(huge), ec);  // over the 16 KiB limit: the server closes this socket (maybe mid-write)
    for (int n = 0; n < 1000 && !ec; ++n) {
      big->buffer.consume(big->buffer.size());
      big->ws.read(big->buffer, ec);
    }
    EXPECT_TRUE(ec) << "the oversized sender was not disconnected";
  }
  {
    auto binary = Connect();
    binary->ws.binary(true);
    binary->Send("\x01\x02\x03");
    EXPECT_NE(binary->NextOf("error")["message"].get<std::string>().find("binary message"), std::string::npos);
    binary->ws.binary(false);
    binary->Send(std::string(20, '{'));
    EXPECT_NE(binary->NextOf("error")["message"].get<std::string>().find("not JSON"), std::string::npos);
  }
  for (int k = 0; k < 5; ++k) {
    // connections dropped without a close handshake
    auto rude = Connect();
    rude->ws.next_layer().close();
  }
  {
    // a raw TCP client speaking nonsense
    asio::io_context ioc;
    tcp::socket s(ioc);
    s.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server_->port()));
    asio::write(s, asio::buffer(std::string("\x16\x03\x01 garbage\r\n\r\n")));
  }
  const double t0 = watcher->NextOf("frame")["t"].get<double>();
  double t1 = t0;
  for (int n = 0; n < 40; ++n) t1 = watcher->NextOf("frame")["t"].get<double>();
  EXPECT_GT(t1, t0 + 0.5) << "the simulation kept running";
  EXPECT_EQ(Request(http::verb::get, "/").result(), http::status::ok);
  EXPECT_GE(loop_->counters().refused.load(), 3);
}

TEST_F(ServerTest, StopClosesOpenConnectionsPromptlyAndReleasesThePort) {
  auto page = Connect();
  page->NextOf("frame");
  // a browser's keep-alive connection, idle after one request
  asio::io_context ioc;
  beast::tcp_stream idle(ioc);
  idle.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server_->port()));
  http::request<http::string_body> req(http::verb::get, "/", 11);
  req.set(http::field::host, "127.0.0.1");
  req.keep_alive(true);
  http::write(idle, req);
  beast::flat_buffer buffer;
  http::response<http::string_body> res;
  http::read(idle, buffer, res);
  ASSERT_TRUE(res.keep_alive());
  const int port = server_->port();
  loop_->Stop();
  thread_.join();
  const auto start = std::chrono::steady_clock::now();
  server_->Stop();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
  beast::error_code ec;
  page->buffer.consume(page->buffer.size());
  for (int n = 0; n < 100 && !ec; ++n) page->ws.read(page->buffer, ec);
  EXPECT_TRUE(ec) << "the page's socket was closed";
  server_.reset();
  // the port is free again
  ServerOptions options;
  options.port = port;
  options.web_root = root_.string();
  Server again(options, *loop_);
  EXPECT_EQ(again.port(), port);
  // TearDown stops what is left
  thread_ = std::thread([] {});
  server_ = std::make_unique<Server>(ServerOptions{.port = 0, .web_root = root_.string()}, *loop_);
}

TEST(ServerOptionsTest, AMissingPageOrABusyPortIsAClearError) {
  LiveSim sim(kinematics::LoadShippedRobot("panda"), nullptr, "", LiveSimOptions{.controller = "rmpflow"});
  Realtime loop(sim, {}, {}, {});
  ServerOptions options;
  options.port = 0;
  options.web_root = "/nonexistent-page-dir";
  try {
    Server server(options, loop);
    FAIL() << "a missing page was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the page is not built in '/nonexistent-page-dir'"), std::string::npos);
  }
  const auto root = std::filesystem::temp_directory_path() / fmt::format("rmpmarl-view-port-{}", ::getpid());
  std::filesystem::create_directories(root);
  std::ofstream(root / "index.html") << "x";
  options.web_root = root.string();
  Server first(options, loop);
  options.port = first.port();
  try {
    Server second(options, loop);
    FAIL() << "a busy port was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fmt::format("cannot listen on 127.0.0.1:{}", options.port)),
              std::string::npos) << e.what();
  }
  options.host = "not-an-address";
  EXPECT_THROW(Server(options, loop), InputError);
  std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace rmpmarl::viewer
