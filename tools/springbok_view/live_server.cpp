#include "live_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <netinet/in.h>
#include <openssl/evp.h>
#include <openssl/sha.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "view_page.hpp"

namespace springbok::view {
namespace {

constexpr std::size_t kMaxRequestBytes = 16 * 1024;
constexpr std::size_t kMaxPendingBytes = 1 << 20;  // beyond this a page misses records
constexpr const char* kTelemetryPath = "/telemetry";
// The live page asks for it while loading; it is answered (204) when a page says, over its
// WebSocket ("drawn"), that it has drawn a record: the page's load ends with the robot shown (a
// headless browser that captures at the load, as the browser test's, then shows it).
constexpr const char* kFirstRecordPath = "/first-record";
constexpr const char* kNoContent = "HTTP/1.1 204 No Content\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n";

in_addr parse_ipv4(const std::string& address, const char* what) {
  in_addr a{};
  if (::inet_pton(AF_INET, address.c_str(), &a) != 1) throw Error(fmt::format("{}: '{}' is no IPv4 address", what, address));
  return a;
}

int bound_port(int fd) {
  sockaddr_in at{};
  socklen_t len = sizeof at;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&at), &len);
  return ntohs(at.sin_port);
}

int bound_socket(int type, const std::string& address, int port, const char* what) {
  const int fd = ::socket(AF_INET, type | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw Error(fmt::format("{}: socket: {}", what, std::strerror(errno)));
  const int yes = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  sockaddr_in at{};
  at.sin_family = AF_INET;
  at.sin_port = htons(static_cast<std::uint16_t>(port));
  at.sin_addr = parse_ipv4(address, what);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&at), sizeof at) != 0) {
    const int e = errno;
    ::close(fd);
    throw Error(fmt::format("{}: cannot bind {}:{}: {}", what, address, port, std::strerror(e)));
  }
  return fd;
}

// A header's value in an HTTP request (names case-insensitive), or "".
std::string header_value(const std::string& request, std::string_view name) {
  std::size_t line = request.find("\r\n");
  while (line != std::string::npos && line + 2 < request.size()) {
    const std::size_t start = line + 2;
    const std::size_t end = request.find("\r\n", start);
    const std::string_view l(request.data() + start, (end == std::string::npos ? request.size() : end) - start);
    const std::size_t colon = l.find(':');
    if (colon == name.size() &&
        std::equal(name.begin(), name.end(), l.begin(), [](char a, char b) { return std::tolower(a) == std::tolower(b); })) {
      std::string_view v = l.substr(colon + 1);
      while (!v.empty() && (v.front() == ' ' || v.front() == '\t')) v.remove_prefix(1);
      while (!v.empty() && (v.back() == ' ' || v.back() == '\t')) v.remove_suffix(1);
      return std::string(v);
    }
    line = end;
  }
  return {};
}

std::string http_response(std::string_view status, std::string_view type, std::string_view body) {
  return fmt::format("HTTP/1.1 {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n"
                     "Connection: close\r\n\r\n{}",
                     status, type, body.size(), body);
}

// One unmasked text frame (server to client frames are not masked: RFC 6455 5.1).
void append_text_frame(std::string& out, const char* data, std::size_t size) {
  out += static_cast<char>(0x81);  // FIN, text
  if (size < 126) {
    out += static_cast<char>(size);
  } else if (size < 65536) {
    out += static_cast<char>(126);
    out += static_cast<char>((size >> 8) & 0xff);
    out += static_cast<char>(size & 0xff);
  } else {
    out += static_cast<char>(127);
    for (int shift = 56; shift >= 0; shift -= 8) out += static_cast<char>((size >> shift) & 0xff);
  }
  out.append(data, size);
}

}  // namespace

std::string websocket_accept(const std::string& key) {
  const std::string text = key + "258EAFA5-E914-47DA-95CA-C5AB0DC85B11";  // RFC 6455 4.2.2
  unsigned char digest[SHA_DIGEST_LENGTH];
  unsigned int digest_size = 0;
  if (::EVP_Digest(text.data(), text.size(), digest, &digest_size, ::EVP_sha1(), nullptr) != 1 ||
      digest_size != SHA_DIGEST_LENGTH) {
    throw Error("SHA-1 for the WebSocket handshake failed");
  }
  unsigned char encoded[4 * ((SHA_DIGEST_LENGTH + 2) / 3) + 1];
  const int n = ::EVP_EncodeBlock(encoded, digest, SHA_DIGEST_LENGTH);
  return std::string(reinterpret_cast<const char*>(encoded), static_cast<std::size_t>(n));
}

LiveServer::LiveServer(LiveOptions options) : options_(std::move(options)) {
  page_ = page_html(fmt::format("window.SPRINGBOK_LIVE = {{\"path\": \"{}\"}};", kTelemetryPath));
  http_fd_ = bound_socket(SOCK_STREAM, options_.http_address, options_.http_port, "--address/--port");
  if (::listen(http_fd_, 16) != 0) throw Error(fmt::format("listen: {}", std::strerror(errno)));
  http_port_ = bound_port(http_fd_);
  udp_fd_ = bound_socket(SOCK_DGRAM, options_.telemetry_address, options_.telemetry_port, "telemetry");
  telemetry_port_ = bound_port(udp_fd_);
}

LiveServer::~LiveServer() {
  for (auto& c : clients_) ::close(c.fd);
  if (http_fd_ >= 0) ::close(http_fd_);
  if (udp_fd_ >= 0) ::close(udp_fd_);
}

void LiveServer::accept_client() {
  while (true) {
    const int fd = ::accept4(http_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    clients_.push_back(Client{fd, false, {}, {}});
  }
}

// False: the client is done (closed, refused, or its response sent and the socket to close).
bool LiveServer::read_client(Client& c) {
  char buf[4096];
  while (true) {
    const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
    if (n == 0) return false;
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) break;
      return false;
    }
    c.in.append(buf, static_cast<std::size_t>(n));
    if (!c.websocket && c.in.size() > kMaxRequestBytes) return false;
  }
  if (c.websocket) {
    // The page sends "drawn" (a text frame) once, and control frames; a close frame ends it.
    while (c.in.size() >= 2) {
      const auto b0 = static_cast<unsigned char>(c.in[0]), b1 = static_cast<unsigned char>(c.in[1]);
      std::size_t length = b1 & 0x7f, header = 2;
      if (length == 126) {
        if (c.in.size() < 4) break;
        length = (static_cast<unsigned char>(c.in[2]) << 8) | static_cast<unsigned char>(c.in[3]);
        header = 4;
      } else if (length == 127) {
        return false;  // no page sends such frames to a viewer
      }
      if ((b1 & 0x80) != 0) header += 4;  // the mask
      if (c.in.size() < header + length) break;
      if ((b0 & 0x0f) == 0x8) return false;
      if ((b0 & 0x0f) == 0x1 && (b1 & 0x80) != 0 && length == 5) {  // client frames are masked
        std::string text = c.in.substr(header, length);
        for (std::size_t i = 0; i < length; ++i) text[i] = static_cast<char>(text[i] ^ c.in[header - 4 + i % 4]);
        if (text == "drawn") release_awaiting();
      }
      c.in.erase(0, header + length);
    }
    return true;
  }
  const std::size_t end = c.in.find("\r\n\r\n");
  if (end == std::string::npos) return true;  // more to come
  const std::string request = c.in.substr(0, end + 2);
  c.in.erase(0, end + 4);
  const std::size_t sp1 = request.find(' '), sp2 = request.find(' ', sp1 + 1);
  const std::string method = request.substr(0, sp1);
  const std::string path = sp1 == std::string::npos ? "" : request.substr(sp1 + 1, sp2 - sp1 - 1);
  if (method != "GET") {
    c.out += http_response("405 Method Not Allowed", "text/plain", "GET only\n");
  } else if (path == kTelemetryPath) {
    const std::string key = header_value(request, "Sec-WebSocket-Key");
    std::string upgrade = header_value(request, "Upgrade");
    std::transform(upgrade.begin(), upgrade.end(), upgrade.begin(), [](char ch) { return std::tolower(ch); });
    if (upgrade != "websocket" || key.empty()) {
      c.out += http_response("400 Bad Request", "text/plain", "a WebSocket upgrade is expected here\n");
    } else {
      c.out += fmt::format("HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                           "Sec-WebSocket-Accept: {}\r\n\r\n",
                           websocket_accept(key));
      c.websocket = true;
      return flush(c);
    }
  } else if (path == kFirstRecordPath) {
    if (!drawn_) {
      c.awaiting_record = true;
      return true;
    }
    c.out += kNoContent;
  } else if (path == "/" || path == "/index.html") {
    c.out += http_response("200 OK", "text/html; charset=utf-8", page_);
  } else {
    c.out += http_response("404 Not Found", "text/plain", "not here: / is the viewer\n");
  }
  // A plain response: sent (what does not fit now, blocking briefly), then the socket closes.
  ::fcntl(c.fd, F_SETFL, ::fcntl(c.fd, F_GETFL) & ~O_NONBLOCK);
  flush(c);
  return false;
}

bool LiveServer::flush(Client& c) {
  while (!c.out.empty()) {
    const ssize_t n = ::send(c.fd, c.out.data(), c.out.size(), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno == EAGAIN || errno == EWOULDBLOCK;
    }
    c.out.erase(0, static_cast<std::size_t>(n));
  }
  return true;
}

void LiveServer::relay(const char* data, std::size_t size) {
  for (auto& c : clients_) {
    if (!c.websocket) continue;
    if (c.out.size() > kMaxPendingBytes) {
      ++counts_.dropped;
      continue;
    }
    append_text_frame(c.out, data, size);
    ++counts_.frames_sent;
  }
}

void LiveServer::release_awaiting() {
  drawn_ = true;
  for (auto& c : clients_) {
    if (!c.awaiting_record) continue;
    c.awaiting_record = false;
    c.out += kNoContent;
    c.close_when_sent = true;
  }
}

void LiveServer::serve(const std::atomic<bool>& stop) {
  std::vector<char> datagram(65536);
  std::vector<pollfd> fds;
  while (!stop.load()) {
    fds.clear();
    fds.push_back({http_fd_, POLLIN, 0});
    fds.push_back({udp_fd_, POLLIN, 0});
    for (const auto& c : clients_) fds.push_back({c.fd, static_cast<short>(POLLIN | (c.out.empty() ? 0 : POLLOUT)), 0});
    if (::poll(fds.data(), fds.size(), 100) < 0) {
      if (errno == EINTR) continue;
      throw Error(fmt::format("poll: {}", std::strerror(errno)));
    }
    if ((fds[0].revents & POLLIN) != 0) accept_client();
    if ((fds[1].revents & POLLIN) != 0) {
      while (true) {
        const ssize_t n = ::recv(udp_fd_, datagram.data(), datagram.size(), 0);
        if (n <= 0) break;
        ++counts_.datagrams;
        // A record is one JSON object; anything else on the port is not relayed.
        if (datagram[0] == '{' && datagram[static_cast<std::size_t>(n) - 1] == '}') {
          relay(datagram.data(), static_cast<std::size_t>(n));
        }
      }
    }
    // The clients polled are the first fds.size() - 2; accepted ones since wait a round.
    const std::size_t polled = fds.size() - 2;
    std::vector<bool> keep(clients_.size(), true);
    for (std::size_t i = 0; i < polled; ++i) {
      const short ev = fds[i + 2].revents;
      if ((ev & (POLLERR | POLLHUP | POLLNVAL)) != 0 && (ev & POLLIN) == 0) keep[i] = false;
      else if ((ev & POLLIN) != 0) keep[i] = read_client(clients_[i]);
    }
    for (std::size_t i = 0; i < clients_.size(); ++i) {
      if (keep[i] && !clients_[i].out.empty()) keep[i] = flush(clients_[i]);
      if (keep[i] && clients_[i].close_when_sent && clients_[i].out.empty()) keep[i] = false;
    }
    std::size_t w = 0;
    for (std::size_t i = 0; i < clients_.size(); ++i) {
      if (keep[i]) {
        if (w != i) clients_[w] = std::move(clients_[i]);
        ++w;
      }
      else ::close(clients_[i].fd);
    }
    clients_.resize(w);
    counts_.pages = static_cast<int>(std::count_if(clients_.begin(), clients_.end(), [](const Client& c) { return c.websocket; }));
  }
}

}  // namespace springbok::view
