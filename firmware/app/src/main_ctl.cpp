// springbokctl: the operator socket's command-line client (README "The operator socket").
//
//   springbokctl [--socket PATH] [--field KEY] [--timeout-ms N] COMMAND [ARG...]
//
// Sends "COMMAND ARG..." as one line and prints the reply: on stdout and exit 0 when
// it is "ok ...", on stderr and exit 1 when it is "error: ...", exit 2 when the
// socket cannot be reached or does not answer in time. --field KEY prints only the
// value of KEY=value in the reply (e.g. `springbokctl --field mode status` -> control),
// exit 1 when the reply has no such key. The socket: --socket, else
// $SPRINGBOK_OPERATOR_SOCKET, else /run/springbok/operator.sock (the shipped config's).
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "springbok/app/operator_client.hpp"

int main(int argc, char** argv) {
  CLI::App app{"springbokctl: send one command to the springbok operator socket and print the reply"};
  const char* env = std::getenv("SPRINGBOK_OPERATOR_SOCKET");
  std::string socket_path = env != nullptr && *env != '\0' ? env : "/run/springbok/operator.sock";
  std::string key;
  int timeout_ms = 2000;
  std::vector<std::string> words;
  app.add_option("--socket", socket_path, "the operator socket (default: $SPRINGBOK_OPERATOR_SOCKET, else "
                                          "/run/springbok/operator.sock)");
  app.add_option("--field", key, "print only the value of KEY=value in the reply");
  app.add_option("--timeout-ms", timeout_ms, "how long to wait for the reply")->check(CLI::Range(1, 600000));
  app.add_option("command", words,
                 "the command and its arguments: start | stop | reset | mode stand | mode control | status | "
                 "gait stand | gait trot [key=value ...] | walk VX VY YAW_RATE | tare | controller")
      ->required();
  app.footer("Exit status: 0 the reply is ok, 1 it is an error (or --field's key is missing), 2 no reply.");
  CLI11_PARSE(app, argc, argv);

  std::string line;
  for (const std::string& w : words) line += (line.empty() ? "" : " ") + w;
  springbok::app::OperatorClient client(socket_path);
  std::string reply, error;
  if (!client.exchange(line, timeout_ms, reply, error)) {
    std::fprintf(stderr, "springbokctl: %s\n", error.c_str());
    return 2;
  }
  if (reply.rfind("ok", 0) != 0) {
    std::fprintf(stderr, "%s\n", reply.c_str());
    return 1;
  }
  if (!key.empty()) {
    std::string value;
    if (!springbok::app::reply_field(reply, key, value)) {
      std::fprintf(stderr, "springbokctl: no %s= in the reply: %s\n", key.c_str(), reply.c_str());
      return 1;
    }
    std::printf("%s\n", value.c_str());
    return 0;
  }
  std::printf("%s\n", reply.c_str());
  return 0;
}
