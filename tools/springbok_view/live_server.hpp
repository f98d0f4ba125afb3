// springbok-view's live mode: serves the viewer's page over HTTP and relays the firmware's
// telemetry datagrams (UDP, one JSON object each: firmware/app/README.md) to every page over a
// WebSocket (RFC 6455, server to page, text frames). One thread, poll(): a tool beside the
// robot, not on its tick. A page that cannot keep up misses records (the newest one is what
// it draws), never blocks the others.
#pragma once

#include <atomic>
#include <string>
#include <vector>

namespace springbok::view {

struct LiveOptions {
  std::string http_address = "127.0.0.1";
  int http_port = 8090;
  std::string telemetry_address = "0.0.0.0";  // where the firmware's datagrams arrive
  int telemetry_port = 9870;
};

struct LiveCounts {
  long long datagrams = 0;     // received from the firmware
  long long frames_sent = 0;   // WebSocket frames written to pages
  long long dropped = 0;       // records a slow page missed
  int pages = 0;               // connected now
};

// Serves until `stop` is set (a signal handler sets it); `ready()` once listening (the port
// bound, as the tests use it). Throws Error on a socket it cannot open.
class LiveServer {
 public:
  explicit LiveServer(LiveOptions options);
  ~LiveServer();
  LiveServer(const LiveServer&) = delete;
  LiveServer& operator=(const LiveServer&) = delete;

  int http_port() const { return http_port_; }  // the bound ports (0 asked: the kernel's choice)
  int telemetry_port() const { return telemetry_port_; }
  void serve(const std::atomic<bool>& stop);
  LiveCounts counts() const { return counts_; }

 private:
  struct Client {
    int fd = -1;
    bool websocket = false;   // upgraded; else still reading its HTTP request
    std::string in;           // what it sent, not yet handled
    std::string out;          // what it has not yet taken
    bool awaiting_record = false;  // GET /first-record: answered once a page has been sent one
    bool close_when_sent = false;
  };
  void accept_client();
  bool read_client(Client& c);
  void relay(const char* data, std::size_t size);
  bool flush(Client& c);
  void release_awaiting();

  LiveOptions options_;
  int http_fd_ = -1;
  int udp_fd_ = -1;
  int http_port_ = 0;
  int telemetry_port_ = 0;
  std::string page_;
  std::vector<Client> clients_;
  bool drawn_ = false;  // a page has drawn a record (GET /first-record is answered at once)
  LiveCounts counts_;
};

// The WebSocket handshake's Sec-WebSocket-Accept for a client's Sec-WebSocket-Key.
std::string websocket_accept(const std::string& key);

}  // namespace springbok::view
