// Replays a pmon recording through the pmon C API and prints one JSON line per object and frame (and one per
// missed object and per cluster the region of interest excused), with the fields of `pmon check --format jsonl`.
// C++17, no dependencies beyond libpmon_capi.
//
//   pmon_replay RECORDING_DIR [PARAMS.toml | profile:NAME]
//
// Exit codes as `pmon check`: 0 no alarm, 1 alarms, 2 bad input.
#include <charconv>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "pmon.h"

namespace {

std::string last_error() {
  std::string msg(pmon_last_error(nullptr, 0) + 1, '\0');
  pmon_last_error(msg.data(), msg.size());
  msg.resize(msg.size() - 1);
  return msg;
}

// Shortest round-trip text of a number, as JSON writers print them.
template <typename T>
std::string num(T v) {
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string text(const uint8_t* s) { return std::string(reinterpret_cast<const char*>(s)); }

std::string str(const std::string& s) { return "\"" + s + "\""; }  // pmon's names need no escaping

template <typename T, size_t N>
std::string arr(const T (&a)[N]) {
  std::string out = "[";
  for (size_t i = 0; i < N; ++i) out += (i ? "," : "") + num(a[i]);
  return out + "]";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: %s RECORDING_DIR [PARAMS.toml | profile:NAME]\n", argv[0]);
    return 2;
  }
  PmonMonitor* raw_monitor = nullptr;
  // PARAMS: a TOML file, or profile:NAME for a profile pmon ships (as `pmon check --params`).
  int32_t rc = argc == 3 ? pmon_monitor_new_from_file(argv[2], &raw_monitor) : pmon_monitor_new(nullptr, &raw_monitor);
  if (rc != PMON_OK) {
    std::fprintf(stderr, "error: %s\n", last_error().c_str());
    return 2;
  }
  std::unique_ptr<PmonMonitor, decltype(&pmon_monitor_free)> monitor(raw_monitor, pmon_monitor_free);
  PmonRecording* raw_rec = nullptr;
  if (pmon_recording_open(argv[1], &raw_rec) != PMON_OK) {
    std::fprintf(stderr, "error: %s\n", last_error().c_str());
    return 2;
  }
  std::unique_ptr<PmonRecording, decltype(&pmon_recording_free)> rec(raw_rec, pmon_recording_free);

  // Caller-owned result buffers, grown only when a frame needs more.
  std::vector<PmonObjectResult> results(256);
  std::vector<PmonCluster> clusters(512);
  bool alarms = false;
  for (;;) {
    PmonFrame frame;
    uint64_t index = 0;
    rc = pmon_recording_next(rec.get(), &frame, &index);
    if (rc == PMON_END) break;
    if (rc != PMON_OK) {
      std::fprintf(stderr, "error: %s\n", last_error().c_str());
      return 2;
    }
    if (results.size() < frame.object_count) results.resize(frame.object_count);
    PmonFrameSummary summary;
    rc = pmon_monitor_check(monitor.get(), &frame, results.data(), results.size(), clusters.data(), clusters.size(),
                            &summary);
    if (rc != PMON_OK) {
      std::fprintf(stderr, "error: frame %llu: %s\n", static_cast<unsigned long long>(index), last_error().c_str());
      return 2;
    }
    const std::string head = "{\"frame\":" + num(index) + ",\"timestamp_s\":" + num(frame.timestamp_s);
    for (size_t i = 0; i < summary.object_count; ++i) {
      const PmonObjectResult& r = results[i];
      const char* cls = pmon_class_name(frame.objects[i].class_);
      std::string line = head + ",\"id\":" + num(r.id) + ",\"class\":" + str(cls ? cls : "unknown") +
                         ",\"verdict\":" + str(text(r.verdict_name));
      if (r.reason_name[0]) line += ",\"reason\":" + str(text(r.reason_name));
      if (r.conditions_text[0]) line += ",\"conditions\":" + str(text(r.conditions_text));
      if (r.position_cause_name[0]) line += ",\"position_cause\":" + str(text(r.position_cause_name));
      line += ",\"sensor\":" + str(text(r.sensor_text)) + ",\"motion\":" + str(text(r.motion_text)) +
              ",\"eta\":" + num(r.eta) + ",\"margin_length_m\":" + num(r.margin_length_m) +
              ",\"margin_width_m\":" + num(r.margin_width_m) + ",\"visible_fraction\":" + num(r.visible_fraction) +
              ",\"offset_m\":" + arr(r.offset_m) + ",\"dt_s\":" + num(r.dt_s) + ",\"accel_mps2\":" + num(r.accel_mps2) +
              ",\"accel_margin_mps2\":" + num(r.accel_margin_mps2) + ",\"turn_rate_radps\":" + num(r.turn_rate_radps) +
              ",\"turn_rate_margin_radps\":" + num(r.turn_rate_margin_radps) +
              ",\"predicted_world_m\":" + arr(r.predicted_world_m) +
              ",\"predicted_margin_m\":" + arr(r.predicted_margin_m) +
              ",\"position_residual_m\":" + num(r.position_residual_m) +
              ",\"position_allowance_m\":" + num(r.position_allowance_m);
      if (r.kind_name[0]) {
        line += ",\"kind\":" + str(text(r.kind_name)) + ",\"error_size\":" + num(r.error_size) +
                ",\"error_unit\":" + str(text(r.error_unit)) + ",\"severity\":" + num(r.severity);
      }
      line += "}";
      std::puts(line.c_str());
      if (r.verdict != PMON_VERDICT_CONSISTENT && r.verdict != PMON_VERDICT_NOT_MONITORED) alarms = true;
    }
    for (size_t i = 0; i < summary.cluster_count; ++i) {
      const PmonCluster& c = clusters[i];
      if (!c.is_missed_object) continue;
      alarms = true;
      std::puts((head + ",\"verdict\":\"missed_object\",\"centroid_m\":" + arr(c.centroid_m) +
                 ",\"bounds_m\":" + arr(c.bounds_m) + ",\"cells\":" + num(c.cells) + "}")
                    .c_str());
    }
    // The clusters the region of interest excused, with the reason (not alarms).
    for (size_t i = 0; i < summary.cluster_count; ++i) {
      const PmonCluster& c = clusters[i];
      if (!c.is_outside_roi) continue;
      std::puts((head + ",\"verdict\":\"outside_roi\",\"reason\":" + str(text(c.roi_name)) +
                 ",\"centroid_m\":" + arr(c.centroid_m) + ",\"bounds_m\":" + arr(c.bounds_m) +
                 ",\"cells\":" + num(c.cells) + "}")
                    .c_str());
    }
    if (summary.clusters_available > summary.cluster_count) {
      clusters.resize(summary.clusters_available);  // room for the next frame; this one is reported as truncated
      std::fprintf(stderr, "warning: frame %llu: %zu clusters did not fit\n", static_cast<unsigned long long>(index),
                   summary.clusters_available - summary.cluster_count);
    }
  }
  return alarms ? 1 : 0;
}
