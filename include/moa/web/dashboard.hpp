// The live dashboard: a small HTTP server (Debian's cpp-httplib) for `moa
// live --serve`. GET / is one self-contained page (Chart.js and the page's
// script inlined, as the report page; it references nothing outside itself);
// GET /events is a Server-Sent Events stream, one JSON object per event:
//
//   {"t", "x", "y", "theta",              s, m, m, rad: pose at the event
//    "vx", "vy", "omega",                 m/s, rad/s: twist of the last epoch
//    "source",                            "mice" | "wheels" | "hold"
//    "heading",                           heading source of the last epoch: "gyro"
//                                         (its rotation was the gyro's), else "source"
//    "heading_gyro",                      of the epochs, those whose heading was the gyro's
//    "epochs",                            epochs summed into this event
//    "sensors": [{"name", "dx", "dy",     counts summed over those epochs
//                 "squal",                lowest SQUAL (null: none reported)
//                 "flags",                OR of the rows' flags
//                 "used",                 used in the last epoch
//                 "used_share",           share of the epochs it was used in
//                 "excluded"}],           last reason it was left out (null: never)
//    "scales": [[sx, sy], ...],           only when self-calibration estimates exist
//    "gyro": {"bias", "bias_sd",          only with a gyro stream (imu.csv rows): its
//             "scale", "scale_sd",        calibration after the last epoch (rad/s; reading
//             "test"}}                    per true rate) and that epoch's test ratio
//                                         (1: the gate; null: not tested)
//
// GET /status is the server's counts, {"events", "dropped", "clients",
// "greeted", "refused", "ended"} (Stats, and whether finish() was called): what a
// watcher polls to see that a page is connected and being fed.
//
// A client that connects first gets "event: history" (the trajectory and
// the twist so far, {"points": [[t, x, y, vx, vy, omega], ...]}, the last
// history_points events: s, m, m, m/s, m/s, rad/s), then one "event:
// warning" ({"text"}) per warning of the run so far; later warnings come as
// they happen, and when the run ends "event: end" ({"t"}: its last time, s).
// A client that connects after the end gets all of these at once.
//
// Threads: publish() is called by the estimator for every epoch. It sums
// the epoch into the pending event and, at most max_rate times per second
// of wall time, turns it into JSON and appends it to every client's queue
// under a mutex that no socket operation ever holds; a client's queue keeps
// the newest client_queue events (a slow client loses the oldest). Each
// client is served by its own thread of the server's pool, which waits on
// its queue and writes to the socket. So a slow or stuck client never slows
// the estimator, memory is bounded by max_clients x client_queue events, and
// clients beyond max_clients are answered 503.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include "moa/core/odometry.hpp"
#include "moa/core/options_check.hpp"
#include "moa/formats/config.hpp"

namespace moa::io {

struct DashboardOptions {
  std::string host = "127.0.0.1";
  int port = 8080;                ///< 0: any free port (see Dashboard::port())
  int max_clients = 8;            ///< /events streams at once
  std::size_t client_queue = 32;  ///< events waiting per client; older ones dropped
  /// Bytes of kernel send buffer per client socket (SO_SNDBUF; the kernel
  /// doubles it): with client_queue, what one client can hold up.
  int send_buffer = 65536;
  double max_rate = 20.0;             ///< events per second of wall time, at most
  std::size_t history_points = 4000;  ///< trajectory points kept for new clients
  std::size_t max_warnings = 100;     ///< warnings kept for new clients
  std::string title = "moa live";
  /// nullopt when usable, else the first field out of its bounds, the bound
  /// and the value (core/options_check.hpp).
  OptionCheck validate() const;
};

/// "[HOST:]PORT" (host defaults to 127.0.0.1; "[::1]:PORT" for IPv6) into
/// options.host and options.port; throws io::Error naming `flag`.
void parse_listen_address(std::string_view text, std::string_view flag, DashboardOptions& options);

/// The page served at / for `config` (self-contained HTML).
std::string dashboard_page(const RobotConfig& config, std::string_view title);

class Dashboard {
 public:
  /// Binds and starts serving; throws io::Error "HOST:PORT: cannot listen".
  Dashboard(const RobotConfig& config, const DashboardOptions& options);
  /// finish(), then stops the server (waits at most ~1 s for clients).
  ~Dashboard();
  Dashboard(const Dashboard&) = delete;
  Dashboard& operator=(const Dashboard&) = delete;

  int port() const;
  /// http://HOST:PORT/
  std::string url() const;

  /// From the estimator's thread, every epoch; never blocks on a client.
  /// `scales`: per sensor (sx, sy) from self-calibration, empty when none.
  void publish(const OdometryStep& step, std::span<const Eigen::Vector2d> scales = {});
  /// A warning of the run (one line), as the run summary has it: sent to
  /// every client and kept for later ones (the first max_warnings; later
  /// ones are counted in a last warning).
  void warn(const std::string& text);
  /// Ends every stream with "event: end"; later clients get the history,
  /// the warnings and the end at once.
  void finish();

  struct Stats {
    std::size_t events = 0;   ///< events made
    std::size_t dropped = 0;  ///< events dropped from slow clients' queues
    std::size_t clients = 0;  ///< /events streams open now
    /// /events streams greeted so far (sent the history): every event made
    /// after a stream's greeting is sent to it, unless dropped.
    std::size_t greeted = 0;
    std::size_t refused = 0;  ///< /events requests answered 503
  };
  Stats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace moa::io
