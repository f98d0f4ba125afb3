// springbok-view's live mode without a browser: the page served, the WebSocket handshake
// (RFC 6455's own example), a telemetry datagram relayed as a frame, a config without
// telemetry refused. No simulator: these run in every native build, the sanitizers' too.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "live_server.hpp"
#include "run_command.hpp"
#include "springbok/app/telemetry.hpp"

namespace {
using namespace springbok;
namespace fs = std::filesystem;

int connect_to(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in at{};
  at.sin_family = AF_INET;
  at.sin_port = htons(static_cast<std::uint16_t>(port));
  at.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&at), sizeof at), 0);
  timeval timeout{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  return fd;
}

std::string receive(int fd, std::size_t at_least, const std::string& until = "") {
  std::string got;
  char buf[65536];
  while (got.size() < at_least || (!until.empty() && got.find(until) == std::string::npos)) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, static_cast<std::size_t>(n));
  }
  return got;
}

TEST(ViewLive, WebSocketAcceptIsRfc6455s) {
  EXPECT_EQ(view::websocket_accept("dGhlIHNhbXBsZSBub25jZQ=="), "s3pPLMBiTxaQ9kYGzzhZRbK+xOo=");  // RFC 6455 1.3
}

TEST(ViewLive, ServesThePageAndRelaysTelemetryToTheWebSocket) {
  view::LiveServer server({"127.0.0.1", 0, "127.0.0.1", 0});
  std::atomic<bool> stop{false};
  std::thread serving([&] { server.serve(stop); });

  const int page = connect_to(server.http_port());
  const std::string get = "GET / HTTP/1.1\r\nHost: x\r\n\r\n";
  ::send(page, get.data(), get.size(), 0);
  const std::string html = receive(page, 1, "</html>");
  EXPECT_NE(html.find("HTTP/1.1 200 OK"), std::string::npos);
  EXPECT_NE(html.find("window.SPRINGBOK_LIVE"), std::string::npos);
  EXPECT_NE(html.find("window.SPRINGBOK_ROBOT"), std::string::npos);
  ::close(page);
  // What is not the page or the relay is refused, saying so.
  for (const auto& [request, status] : {std::pair<std::string, std::string>{"GET /nope HTTP/1.1\r\n\r\n", "404 Not Found"},
                                        {"POST / HTTP/1.1\r\n\r\n", "405 Method Not Allowed"},
                                        {"GET /telemetry HTTP/1.1\r\n\r\n", "400 Bad Request"}}) {
    const int fd = connect_to(server.http_port());
    ::send(fd, request.data(), request.size(), 0);
    const std::string reply = receive(fd, 1, "\r\n\r\n");
    EXPECT_EQ(reply.rfind("HTTP/1.1 " + status, 0), 0u) << request << reply;
    ::close(fd);
  }

  const int ws = connect_to(server.http_port());
  const std::string upgrade =
      "GET /telemetry HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
  ::send(ws, upgrade.data(), upgrade.size(), 0);
  const std::string reply = receive(ws, 1, "\r\n\r\n");
  EXPECT_NE(reply.find("101 Switching Protocols"), std::string::npos) << reply;
  EXPECT_NE(reply.find("Sec-WebSocket-Accept: s3pPLMBiTxaQ9kYGzzhZRbK+xOo="), std::string::npos) << reply;

  // The firmware's datagram, as its telemetry sender writes it.
  app::TelemetryRecord record;
  record.timestamp_s = 12.5;
  record.q_rad[2] = -1.25;
  const std::string json = app::telemetry_json(record);
  ASSERT_GT(json.size(), 125u);  // a 16-bit length frame
  const int udp = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(server.telemetry_port()));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  // Until the page is registered as a WebSocket the server may not relay: send until a frame comes.
  std::string frame;
  for (int attempt = 0; attempt < 50 && frame.size() < 4 + json.size(); ++attempt) {
    ::sendto(udp, json.data(), json.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
    timeval shortwait{0, 100000};
    ::setsockopt(ws, SOL_SOCKET, SO_RCVTIMEO, &shortwait, sizeof shortwait);
    frame += receive(ws, 4 + json.size());
  }
  ASSERT_GE(frame.size(), 4 + json.size());
  EXPECT_EQ(static_cast<unsigned char>(frame[0]), 0x81);  // FIN, text
  EXPECT_EQ(static_cast<unsigned char>(frame[1]), 126);
  EXPECT_EQ((static_cast<unsigned char>(frame[2]) << 8) | static_cast<unsigned char>(frame[3]), static_cast<int>(json.size()));
  EXPECT_EQ(frame.substr(4, json.size()), json);
  ::close(udp);
  ::close(ws);
  stop = true;
  serving.join();
  EXPECT_GE(server.counts().datagrams, 1);
  EXPECT_GE(server.counts().frames_sent, 1);
}

TEST(ViewLive, TheToolRefusesAConfigWithoutTelemetry) {
  const fs::path config = fs::temp_directory_path() / ("springbok_view_no_telemetry_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(config) << "telemetry: {enabled: false}\n";
  const auto r = test::run_program("", "springbok-view", "--config " + config.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("telemetry"), std::string::npos) << r.out;
  fs::remove(config);
}

}  // namespace
