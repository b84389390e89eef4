#include "moa/web/dashboard.hpp"
#include "moa/web/html.hpp"

#include <arpa/inet.h>
#include <fmt/core.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "dashboard_assets.hpp"
#include "moa/formats/error.hpp"
#include "moa/formats/json.hpp"
#include "moa/formats/odometry_csv.hpp"
#include "moa/runs/run_summary.hpp"
#include "report_assets.hpp"

namespace moa::io {
namespace {

// Workers beyond max_clients (see Dashboard::Dashboard).
constexpr int kSpareWorkers = 32;
// us, the longest pause within a request's bytes.
constexpr long kRequestReadTimeoutUs = 500000;
// The bounds of one request (Debian's cpp-httplib 0.11 has none on the
// number of header lines nor on a chunked body): a dashboard serves GETs,
// whose request line and headers a browser sends in a few hundred bytes.
constexpr std::size_t kMaxRequestBytes = 16384;  // read from a request, all told
constexpr auto kMaxRequestTime = std::chrono::seconds(5);
constexpr int kMaxRequestsPerConnection = 16;
constexpr int kKeepAliveMs = 1000;  // idle between requests on a connection
constexpr int kWriteTimeoutMs = 2000;

// One connection's bytes as cpp-httplib's Stream, with the bounds above:
// past kMaxRequestBytes or kMaxRequestTime of one request, or a pause of
// kRequestReadTimeoutUs, a read fails and the connection is closed. Writes
// wait at most kWriteTimeoutMs for room (a client that reads nothing is
// dropped), never raise SIGPIPE.
class BoundedStream final : public httplib::Stream {
 public:
  explicit BoundedStream(int sock) : sock_(sock) {}
  // A new request: its budget of bytes and time.
  void begin_request() {
    left_ = kMaxRequestBytes;
    deadline_ = std::chrono::steady_clock::now() + kMaxRequestTime;
  }
  bool is_readable() const override { return wait(POLLIN, kRequestReadTimeoutUs / 1000); }
  bool is_writable() const override { return wait(POLLOUT, kWriteTimeoutMs); }
  ssize_t read(char* ptr, size_t size) override {
    if (left_ == 0 || std::chrono::steady_clock::now() >= deadline_) return -1;
    if (!is_readable()) return -1;
    const ssize_t n = ::recv(sock_, ptr, std::min(size, left_), 0);
    if (n > 0) left_ -= static_cast<std::size_t>(n);
    return n;
  }
  ssize_t write(const char* ptr, size_t size) override {
    if (!is_writable()) return -1;
    return ::send(sock_, ptr, size, MSG_NOSIGNAL);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    address(true, ip, port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    address(false, ip, port);
  }
  socket_t socket() const override { return sock_; }

 private:
  bool wait(short events, int ms) const {
    pollfd p{sock_, events, 0};
    int r = 0;
    do {
      r = ::poll(&p, 1, ms);
    } while (r < 0 && errno == EINTR);
    return r > 0 && (p.revents & events) != 0;
  }
  void address(bool peer, std::string& ip, int& port) const {
    sockaddr_storage a{};
    socklen_t length = sizeof a;
    auto* any = reinterpret_cast<sockaddr*>(&a);
    ip.clear();
    port = 0;
    if ((peer ? ::getpeername(sock_, any, &length) : ::getsockname(sock_, any, &length)) != 0) {
      return;
    }
    char text[INET6_ADDRSTRLEN] = {};
    if (a.ss_family == AF_INET) {
      const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
      ::inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
      port = ntohs(v4->sin_port);
    } else if (a.ss_family == AF_INET6) {
      const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
      ::inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
      port = ntohs(v6->sin6_port);
    }
    ip = text;
  }

  int sock_;
  std::size_t left_ = kMaxRequestBytes;
  std::chrono::steady_clock::time_point deadline_ = std::chrono::steady_clock::now();
};

// Set by the pre-routing handler of the worker's request when it refused
// it: the connection is then closed, its unread bytes never read.
thread_local bool t_refused = false;

// cpp-httplib's server with each connection read through BoundedStream:
// the keep-alive loop of httplib's own process_and_close_socket, whose
// reads have no bound. Overrides the library's (private) virtual.
class BoundedServer final : public httplib::Server {
 private:
  bool process_and_close_socket(socket_t sock) override {
    BoundedStream stream(sock);
    bool ok = false;
    for (int k = 0; k < kMaxRequestsPerConnection && svr_sock_ != INVALID_SOCKET; ++k) {
      pollfd p{sock, POLLIN, 0};
      if (::poll(&p, 1, kKeepAliveMs) <= 0) break;  // idle, closed or interrupted: done
      stream.begin_request();
      t_refused = false;
      bool closed = false;
      ok = process_request(stream, k + 1 == kMaxRequestsPerConnection, closed, nullptr);
      if (!ok || closed || t_refused) break;
    }
    ::shutdown(sock, SHUT_RDWR);
    ::close(sock);
    return ok;
  }
};

}  // namespace

OptionCheck DashboardOptions::validate() const {
  return OptionsCheck()
      .require(!host.empty(), "host", "must not be empty")
      .closed("port", port, 0, 65535)
      .closed("max_clients", max_clients, 1, 64)
      .closed("client_queue", static_cast<double>(client_queue), 1, 4096)
      .positive("max_rate", max_rate)
      .at_most("max_rate", max_rate, 100.0)  // events/s
      .closed("send_buffer", send_buffer, 1024, 1 << 24)
      .at_most("history_points", static_cast<double>(history_points), 1e6)
      .at_most("max_warnings", static_cast<double>(max_warnings), 1e4)
      .result();
}

void parse_listen_address(std::string_view text, std::string_view flag, DashboardOptions& options) {
  std::string_view host;
  std::string_view port = text;
  if (const auto colon = text.rfind(':'); colon != std::string_view::npos) {
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
      host = host.substr(1, host.size() - 2);
    }
    if (host.empty()) {
      throw Error(fmt::format("{} {}: empty host (give [HOST:]PORT)", flag, text));
    }
  }
  int value = -1;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
  if (port.empty() || ec != std::errc{} || end != port.data() + port.size() || value < 0 ||
      value > 65535) {
    throw Error(
        fmt::format("{} {}: the port must be a number 0..65535 (give [HOST:]PORT)", flag, text));
  }
  if (!host.empty()) options.host = std::string(host);
  options.port = value;
}

namespace {

/// JSON text safe inside a <script> element: '<' only occurs in strings,
/// where \u003c reads back the same.
std::string script_safe(std::string json) {
  std::string out;
  out.reserve(json.size());
  for (const char c : json) {
    if (c == '<') {
      out += "\\u003c";
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

std::string dashboard_page(const RobotConfig& config, std::string_view title) {
  JsonWriter j;
  j.begin_object().member("title", title).key("sensors").begin_array();
  for (int i = 0; i < config.array.size(); ++i) {
    const SensorMount& m = config.array[i];
    j.begin_object()
        .member("name", config.names[static_cast<std::size_t>(i)])
        .member("x", m.position.x())
        .member("y", m.position.y())
        .member("yaw", m.yaw);
    if (m.max_speed) j.member("max_speed", *m.max_speed);
    j.end_object();
  }
  j.end_array().end_object();
  std::string page;
  page += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  page += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  page += fmt::format("<title>{}</title>\n<style>\n", html(title));
  page += dashboard_assets::page_css();
  page += "</style>\n</head>\n<body data-moa-status=\"loading\">\n";
  page += fmt::format("<header><h1>{}</h1><p id=\"status\">connecting</p></header>\n", html(title));
  page +=
      "<div id=\"moa-errors\" class=\"errors\" hidden></div>\n"
      "<main>\n"
      "<section class=\"wide\"><h2>Trajectory</h2><div class=\"plot square\">"
      "<canvas id=\"chart-trajectory\"></canvas></div></section>\n"
      "<section><h2>Sensors</h2><div class=\"plot\"><canvas id=\"chart-health\"></canvas></div>"
      "<table id=\"sensor-table\"><thead><tr><th>sensor</th><th>dx</th><th>dy</th><th>SQUAL</th>"
      "<th>used (last 10 s)</th><th>left out "
      "because</th></tr></thead><tbody></tbody></table></section>\n"
      "<section><h2>Twist</h2><div class=\"plot\"><canvas id=\"chart-twist\"></canvas></div>"
      "<p id=\"heading-source\">heading: -</p></section>\n"
      "<section><h2>Warnings</h2><ul id=\"warnings\"><li>none</li></ul></section>\n"
      "</main>\n";
  page += "<script id=\"moa-config\" type=\"application/json\">" + script_safe(j.str()) +
          "</script>\n<script>\n";
  page += report_assets::chart_js();
  page += "\n</script>\n<script>\n";
  page += dashboard_assets::page_js();
  page += "\n</script>\n</body>\n</html>\n";
  return page;
}

namespace {

using Clock = std::chrono::steady_clock;
using Message = std::shared_ptr<const std::string>;

struct Client {
  std::deque<Message> queue;  ///< guarded by Impl::mutex
};

/// One epoch summed into the event being built.
struct Pending {
  int epochs = 0;
  // The last epoch's (s, m, rad, m/s, rad/s), for the event.
  double t = 0.0;
  Pose2 pose;
  Twist2 twist;
  Source source = Source::kMice;
  const char* heading = "mice";                     ///< heading_source() of the last epoch
  int heading_gyro = 0;                             ///< epochs whose heading was the gyro's
  std::optional<RunSummary::GyroCalibration> gyro;  ///< the last epoch's, with a gyro
  double gyro_test = 0.0;                           ///< the last epoch's test ratio (NaN: none)
  SensorMask used_now = 0;
  std::vector<Eigen::Vector2d> scales;
  std::vector<Eigen::Vector2d> counts;
  std::vector<int> squal;  ///< lowest (ArraySample: 255 when none reported)
  std::vector<unsigned> flags;
  std::vector<int> used;
  std::vector<std::string> excluded;
  void reset(int n) {
    epochs = 0;
    heading_gyro = 0;
    counts.assign(static_cast<std::size_t>(n), Eigen::Vector2d::Zero());
    squal.assign(static_cast<std::size_t>(n), 255);
    flags.assign(static_cast<std::size_t>(n), 0u);
    used.assign(static_cast<std::size_t>(n), 0);
    excluded.assign(static_cast<std::size_t>(n), std::string());
  }
};

}  // namespace

struct Dashboard::Impl {
  RobotConfig config;
  DashboardOptions options;
  std::string page;
  BoundedServer server;
  std::thread listener;
  int port = 0;

  // Estimator thread only.
  Pending pending;
  Clock::time_point last_event{};

  // Guarded by mutex.
  mutable std::mutex mutex;
  std::condition_variable wake;
  std::vector<std::shared_ptr<Client>> clients;
  std::deque<std::array<double, 6>> history;  ///< t, x, y, vx, vy, omega
  std::vector<Message> warnings;              ///< "event: warning" messages
  Message last;                               ///< the last event: the state now
  std::size_t warnings_unsent = 0;            ///< beyond max_warnings
  double t_last = 0.0;                        ///< s, the last event's time
  bool finished = false;
  bool stopping = false;
  Stats stats;

  std::string event_json() const;  // of `pending`
  void emit();                     // `pending` as an event, then reset
  void broadcast(Message message);
  std::string history_message() const;  // with mutex held
  std::string end_message() const;      // with mutex held
  bool serve(const std::shared_ptr<Client>& client, httplib::DataSink& sink, bool& greeted);
};

std::string Dashboard::Impl::event_json() const {
  const Twist2& v = pending.twist;
  JsonWriter j;
  j.begin_object()
      .member("t", pending.t)
      .member("x", pending.pose.t.x())
      .member("y", pending.pose.t.y())
      .member("theta", pending.pose.theta)
      .member("vx", v.v.x())
      .member("vy", v.v.y())
      .member("omega", v.omega)
      .member("source", to_name(pending.source))
      .member("heading", pending.heading)
      .member("heading_gyro", pending.heading_gyro)
      .member("epochs", pending.epochs)
      .key("sensors")
      .begin_array();
  const SensorMask used = pending.used_now;
  for (std::size_t i = 0; i < config.names.size(); ++i) {
    j.begin_object()
        .member("name", config.names[i])
        .member("dx", pending.counts[i].x())
        .member("dy", pending.counts[i].y());
    if (pending.squal[i] >= 255) {  // 255: no SQUAL reported
      j.key("squal").null();
    } else {
      j.member("squal", pending.squal[i]);
    }
    j.member("flags", static_cast<int>(pending.flags[i]))
        .member("used", ((used >> i) & 1u) != 0)
        .member("used_share", pending.epochs > 0 ? static_cast<double>(pending.used[i]) /
                                                       static_cast<double>(pending.epochs)
                                                 : 0.0);
    if (pending.excluded[i].empty()) {
      j.key("excluded").null();
    } else {
      j.member("excluded", pending.excluded[i]);
    }
    j.end_object();
  }
  j.end_array();
  if (!pending.scales.empty()) {
    j.key("scales").begin_array();
    for (const auto& s : pending.scales) j.begin_array().value(s.x()).value(s.y()).end_array();
    j.end_array();
  }
  if (const auto& g = pending.gyro) {
    j.key("gyro")
        .begin_object()
        .member("bias", g->bias)
        .member("bias_sd", g->bias_sd)
        .member("scale", g->scale)
        .member("scale_sd", g->scale_sd)
        .member("latency", g->latency)
        .member("latency_sd", g->latency_sd);
    if (std::isnan(pending.gyro_test)) {
      j.key("test").null();
    } else {
      j.member("test", pending.gyro_test);
    }
    j.end_object();
  }
  j.end_object();
  return j.str();
}

void Dashboard::Impl::broadcast(Message message) {
  {
    const std::lock_guard lock(mutex);
    for (const auto& client : clients) {
      client->queue.push_back(message);
      while (client->queue.size() > options.client_queue) {
        client->queue.pop_front();
        ++stats.dropped;
      }
    }
  }
  wake.notify_all();
}

std::string Dashboard::Impl::history_message() const {
  JsonWriter j;
  j.begin_object().key("points").begin_array();
  for (const auto& p : history) {
    j.begin_array();
    for (const double v : p) j.value(v);
    j.end_array();
  }
  j.end_array().end_object();
  return "event: history\ndata: " + j.str() + "\n\n";
}

std::string Dashboard::Impl::end_message() const {
  JsonWriter j;
  j.begin_object().member("t", t_last).end_object();
  return "event: end\ndata: " + j.str() + "\n\n";
}

// One turn of a client's stream: true to be called again.
bool Dashboard::Impl::serve(const std::shared_ptr<Client>& client, httplib::DataSink& sink,
                            bool& greeted) {
  std::vector<Message> batch;
  std::string greeting;
  std::string ending;
  bool end = false;
  {
    std::unique_lock lock(mutex);
    if (!greeted) {
      greeting = "retry: 2000\n\n" + history_message();
      for (const auto& w : warnings) greeting += *w;
      if (last) greeting += *last;
      client->queue.clear();  // the warnings queued before the greeting are in it
      ++stats.greeted;
    } else {
      wake.wait_for(lock, std::chrono::seconds(1),
                    [&] { return stopping || finished || !client->queue.empty(); });
    }
    if (stopping) return false;
    batch.assign(client->queue.begin(), client->queue.end());
    client->queue.clear();
    end = finished;
    if (end) ending = end_message();
  }
  // Socket writes only from here on, with no lock held.
  if (!greeted) {
    greeted = true;
    if (!sink.write(greeting.data(), greeting.size())) return false;
  }
  for (const auto& m : batch) {
    if (!sink.write(m->data(), m->size())) return false;
  }
  if (end) {
    sink.write(ending.data(), ending.size());
    sink.done();
    return true;
  }
  static constexpr std::string_view kIdle = ": idle\n\n";  // a comment: finds closed clients
  if (batch.empty() && !sink.write(kIdle.data(), kIdle.size())) return false;
  return true;
}

Dashboard::Dashboard(const RobotConfig& config, const DashboardOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  if (const auto e = options.validate()) throw Error(fmt::format("dashboard: {}", e->message()));
  s.config = config;
  s.options = options;
  s.page = dashboard_page(config, options.title);
  s.pending.reset(config.array.size());

  // The streams, and room besides for the page, a 503 and connections that
  // dribble their request (slow-loris): each holds a worker until it sends
  // nothing for kRequestReadTimeout, so kSpareWorkers of them at once still
  // leave one for the page.
  const int threads = options.max_clients + kSpareWorkers;
  s.server.new_task_queue = [threads] {
    return new httplib::ThreadPool(static_cast<std::size_t>(threads));
  };
  // Accepted sockets inherit the listening socket's SO_SNDBUF (Linux).
  s.server.set_socket_options([buffer = options.send_buffer](socket_t sock) {
    const int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    setsockopt(sock, SOL_SOCKET, SO_SNDBUF, &buffer, sizeof buffer);
  });
  s.server.set_keep_alive_timeout(1);  // idle timeout between requests, s
  s.server.set_keep_alive_max_count(16);
  // A browser sends its request at once: a connection that leaves a gap this
  // long within its headers is dropped.
  s.server.set_read_timeout(std::chrono::microseconds(kRequestReadTimeoutUs));
  s.server.set_write_timeout(2, 0);  // a client that reads nothing for 2 s is dropped
  // Beyond BoundedStream's bounds: a body is never read. A request other
  // than a GET (or HEAD) without a body is refused before its body would be
  // read, and its connection closed.
  s.server.set_payload_max_length(0);
  s.server.set_pre_routing_handler([](const httplib::Request& req, httplib::Response& res) {
    const bool get = req.method == "GET" || req.method == "HEAD";
    const bool body =
        req.has_header("Transfer-Encoding") ||
        (req.has_header("Content-Length") && req.get_header_value("Content-Length") != "0");
    if (get && !body) return httplib::Server::HandlerResponse::Unhandled;
    t_refused = true;
    res.status = get ? 413 : 405;
    if (!get) res.set_header("Allow", "GET, HEAD");
    res.set_header("Connection", "close");
    res.set_content(get ? "a request to the dashboard has no body\n"
                        : "the dashboard serves GET requests only\n",
                    "text/plain");
    return httplib::Server::HandlerResponse::Handled;
  });
  s.server.Get("/", [this](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(impl_->page, "text/html; charset=utf-8");
  });
  // The server's counts as one JSON object (Dashboard::Stats and whether the
  // run has ended): what a watcher polls to know a page is connected.
  s.server.Get("/status", [this](const httplib::Request&, httplib::Response& res) {
    const Stats now = stats();
    bool ended = false;
    {
      const std::lock_guard lock(impl_->mutex);
      ended = impl_->finished;
    }
    JsonWriter j;
    j.begin_object()
        .member("events", now.events)
        .member("dropped", now.dropped)
        .member("clients", now.clients)
        .member("greeted", now.greeted)
        .member("refused", now.refused)
        .member("ended", ended)
        .end_object();
    res.set_header("Cache-Control", "no-store");
    res.set_content(j.str() + "\n", "application/json");
  });
  s.server.Get("/events", [this](const httplib::Request&, httplib::Response& res) {
    Impl& d = *impl_;
    auto client = std::make_shared<Client>();
    {
      const std::lock_guard lock(d.mutex);
      if (d.stopping || static_cast<int>(d.clients.size()) >= d.options.max_clients) {
        ++d.stats.refused;
        res.status = 503;
        res.set_content("too many clients\n", "text/plain");
        return;
      }
      d.clients.push_back(client);
    }
    res.set_header("Cache-Control", "no-store");
    auto greeted = std::make_shared<bool>(false);
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, client, greeted](std::size_t, httplib::DataSink& sink) {
          return impl_->serve(client, sink, *greeted);
        },
        [this, client](bool) {
          const std::lock_guard lock(impl_->mutex);
          std::erase(impl_->clients, client);
        });
  });
  s.port = options.port == 0
               ? s.server.bind_to_any_port(options.host)
               : (s.server.bind_to_port(options.host, options.port) ? options.port : -1);
  if (s.port < 0) {
    throw Error(
        fmt::format("{}:{}: cannot listen (address in use, or not an address of this computer?)",
                    options.host, options.port));
  }
  s.listener = std::thread([this] { impl_->server.listen_after_bind(); });
  for (int i = 0; i < 500 && !s.server.is_running(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

Dashboard::~Dashboard() {
  Impl& s = *impl_;
  finish();
  // Let the streams send what they have and the end (at most ~1 s).
  for (int i = 0; i < 100; ++i) {
    {
      const std::lock_guard lock(s.mutex);
      if (s.clients.empty()) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  {
    const std::lock_guard lock(s.mutex);
    s.stopping = true;
  }
  s.wake.notify_all();
  s.server.stop();
  if (s.listener.joinable()) s.listener.join();
}

int Dashboard::port() const { return impl_->port; }

std::string Dashboard::url() const {
  const std::string& host = impl_->options.host;
  return host.find(':') != std::string::npos ? fmt::format("http://[{}]:{}/", host, impl_->port)
                                             : fmt::format("http://{}:{}/", host, impl_->port);
}

void Dashboard::publish(const OdometryStep& step, std::span<const Eigen::Vector2d> scales) {
  Impl& s = *impl_;
  Pending& p = s.pending;
  const RobustEstimate& e = step.estimate;
  const int n = static_cast<int>(s.config.names.size());
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (step.sample) {
      p.counts[k] += step.sample->counts[k];
      p.squal[k] = std::min<int>(p.squal[k], step.sample->squal[k]);
      p.flags[k] |= step.sample->flags[k];
    }
    if ((e.estimate.used >> i) & 1u) {
      ++p.used[k];
    } else {
      p.excluded[k] = describe_exclusion(e.excluded[k], e.noise_flags[k]);
    }
  }
  ++p.epochs;
  p.t = step.t();
  p.pose = step.pose;
  p.twist = e.estimate.twist;
  p.source = e.source;
  p.heading = heading_source(e);
  if (e.tests.gyro_fused) ++p.heading_gyro;
  if (step.gyro != nullptr) {
    p.gyro = RunSummary::GyroCalibration::of(*step.gyro);
    p.gyro_test = e.tests.gyro;
  } else {
    p.gyro.reset();
  }
  p.used_now = e.estimate.used;
  p.scales.assign(scales.begin(), scales.end());
  const auto now = Clock::now();
  if (now - s.last_event < std::chrono::duration<double>(1.0 / s.options.max_rate)) return;
  s.last_event = now;
  s.emit();
}

void Dashboard::Impl::emit() {
  auto message = std::make_shared<const std::string>("data: " + event_json() + "\n\n");
  {
    const std::lock_guard lock(mutex);
    ++stats.events;
    if (options.history_points > 0) {
      if (history.size() >= options.history_points) history.pop_front();
      const Twist2& v = pending.twist;
      history.push_back(
          {pending.t, pending.pose.t.x(), pending.pose.t.y(), v.v.x(), v.v.y(), v.omega});
    }
    t_last = pending.t;
    last = message;
  }
  broadcast(std::move(message));
  pending.reset(static_cast<int>(config.names.size()));
}

void Dashboard::warn(const std::string& text) {
  Impl& s = *impl_;
  Message message;
  {
    const std::lock_guard lock(s.mutex);
    if (s.warnings.size() >= s.options.max_warnings) {
      ++s.warnings_unsent;
      return;
    }
    JsonWriter j;
    j.begin_object().member("text", text).end_object();
    message = std::make_shared<const std::string>("event: warning\ndata: " + j.str() + "\n\n");
    s.warnings.push_back(message);
  }
  s.broadcast(std::move(message));
}

void Dashboard::finish() {
  Impl& s = *impl_;
  {
    const std::lock_guard lock(s.mutex);
    if (s.finished) return;
  }
  // The epochs since the last event: the run's final state.
  if (s.pending.epochs > 0) s.emit();
  Message more;
  {
    const std::lock_guard lock(s.mutex);
    if (s.warnings_unsent > 0) {
      JsonWriter j;
      j.begin_object()
          .member("text", fmt::format("{} more warnings (not kept)", s.warnings_unsent))
          .end_object();
      more = std::make_shared<const std::string>("event: warning\ndata: " + j.str() + "\n\n");
      s.warnings.push_back(more);
    }
  }
  if (more) s.broadcast(more);
  {
    const std::lock_guard lock(impl_->mutex);
    impl_->finished = true;
  }
  impl_->wake.notify_all();
}

Dashboard::Stats Dashboard::stats() const {
  const std::lock_guard lock(impl_->mutex);
  Stats out = impl_->stats;
  out.clients = impl_->clients.size();
  return out;
}

}  // namespace moa::io
