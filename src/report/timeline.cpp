#include "red/report/timeline.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "red/report/html.hpp"

namespace red {

namespace {

// Geometry (SVG user units = CSS pixels).
constexpr double kPxPerMs = 3.0;  // an encoder run (~12 ms) is wide enough for its label
constexpr double kMinPlotWidth = 1100;
constexpr double kMaxPlotWidth = 24000;
constexpr double kLeft = 150;  // row labels
constexpr double kRight = 20;
constexpr double kLaneH = 30;
constexpr double kWaitH = 18;
constexpr double kOpH = 40;
constexpr double kAxisH = 22;
constexpr double kPolicyTitleH = 24;
constexpr double kGap = 16;
constexpr double kCharW = 5.6;    // width of one character at font-size 10 (for fitting labels)
constexpr double kBoldW = 1.15;   // a bold character is this much wider
constexpr double kLabelGap = 12;  // between two labels on one line

// Operation colours: mid-tones that keep black labels legible.
constexpr const char* kOpColors[] = {"#7fb2e5", "#f4a261", "#8fd18b", "#e98f8f",
                                     "#c3a3e6", "#e0c25c", "#7fd1cb", "#f2a5cf"};

const char* op_color(int op) {
  if (op < 0) return "#bbbbbb";
  return kOpColors[static_cast<std::size_t>(op) % std::size(kOpColors)];
}

std::string ms6(TimePoint t) {
  return fmt::format("{:.6f}", to_ms(t));
}

// A nice tick step (1, 2 or 5 × 10^k ms) for about `target` ms between ticks.
double nice_step_ms(double target) {
  const double p = std::pow(10.0, std::floor(std::log10(std::max(target, 1e-6))));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= target) return m * p;
  return 10 * p;
}

// "camera#4:A" members of a units.csv `jobs` field: (operation name, job, node).
struct MemberRef {
  std::string operation;
  std::string job;
  std::string node;
};

std::vector<MemberRef> parse_members(const std::string& jobs) {
  std::vector<MemberRef> out;
  std::size_t i = 0;
  while (i < jobs.size()) {
    std::size_t j = jobs.find(' ', i);
    if (j == std::string::npos) j = jobs.size();
    const std::string m = jobs.substr(i, j - i);
    i = j + 1;
    if (m.empty()) continue;
    MemberRef r;
    const std::size_t hash = m.rfind('#');
    const std::size_t colon = m.find(':', hash == std::string::npos ? 0 : hash);
    r.operation = m.substr(0, hash);
    if (hash != std::string::npos)
      r.job = m.substr(hash + 1, colon == std::string::npos ? std::string::npos : colon - hash - 1);
    if (colon != std::string::npos) r.node = m.substr(colon + 1);
    out.push_back(std::move(r));
  }
  return out;
}

// The label drawn in a unit's box: what it ran, and "×N" for a merged run or a batch.
std::string unit_label(const Scenario& s, const UnitRow& u, const std::vector<MemberRef>& members) {
  const std::string head = u.head >= 0 && static_cast<std::size_t>(u.head) < s.model.heads.size()
                               ? s.model.heads[static_cast<std::size_t>(u.head)]
                               : std::string();
  std::string base;
  switch (u.kind) {
    case UnitKind::Encoder:
      base = "enc";
      break;
    case UnitKind::Head:
      base = head.empty() ? "head" : head;
      break;
    case UnitKind::Coarse:
      base = "enc+" + (head.empty() ? std::string("head") : head);
      break;
    case UnitKind::Mono:
      base = "mono";
      break;
    case UnitKind::Plain:
      base = members.empty() || members.front().node.empty() ? "plain" : members.front().node;
      break;
  }
  if (u.members > 1) base += fmt::format(" \u00d7{}", u.members);
  return base;
}

// Characters (UTF-8 code points) in `text`.
std::size_t glyphs(const std::string& text) {
  std::size_t n = 0;
  for (char c : text) n += (static_cast<unsigned char>(c) & 0xC0U) != 0x80U ? 1 : 0;
  return n;
}

// The label and shorter forms of it, longest first: "enc+seg ×2", "seg ×2", "enc+seg",
// "seg", "×2", "s".
std::vector<std::string> label_forms(const Scenario& s, const UnitRow& u, const std::string& full) {
  std::vector<std::string> out{full};
  const std::string times = u.members > 1 ? fmt::format(" \u00d7{}", u.members) : "";
  std::string base = times.empty() ? full : full.substr(0, full.size() - times.size());
  if (u.kind == UnitKind::Coarse && u.head >= 0 &&
      static_cast<std::size_t>(u.head) < s.model.heads.size()) {
    const std::string& head = s.model.heads[static_cast<std::size_t>(u.head)];
    if (!times.empty()) out.push_back(head + times);
    out.push_back(base);
    base = head;
  }
  if (!times.empty() || base != full) out.push_back(base);
  if (!times.empty()) out.push_back(times.substr(1));
  if (!base.empty()) out.push_back(base.substr(0, 1));
  return out;
}

// The first form that fits in `width` pixels, or null.
const std::string* fitting_label(const std::vector<std::string>& forms, double width) {
  for (const std::string& f : forms)
    if (kCharW * static_cast<double>(glyphs(f)) + 4 <= width) return &f;
  return nullptr;
}

struct Layout {
  TimePoint from, to;
  double px_per_ms = kPxPerMs;
  double width = 0;  // plot area
  [[nodiscard]] double x(TimePoint t) const {
    return kLeft + std::clamp(to_ms(t - from), 0.0, to_ms(to - from)) * px_per_ms;
  }
  [[nodiscard]] double total_width() const { return kLeft + width + kRight; }
};

class SvgWriter {
 public:
  SvgWriter(const Scenario& s, const TimelineWindow& w) : s_(s), w_(w) {
    const double ms = std::max(1e-3, to_ms(w.to - w.from));
    l_.from = w.from;
    l_.to = w.to;
    l_.width = std::clamp(ms * kPxPerMs, kMinPlotWidth, kMaxPlotWidth);
    l_.px_per_ms = l_.width / ms;
    ops_ = s.operation_count();
  }

  std::string render(const std::vector<TimelineRun>& runs) {
    double y = 0;
    std::string body;
    body += legend(y);
    y += 46;
    body += axis(y, true);
    y += kAxisH;
    for (const TimelineRun& r : runs) {
      body += policy_block(r, y);
      y += kGap;
    }
    body += axis(y, false);
    y += kAxisH + 6;
    std::string out = fmt::format(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"red-timeline\" width=\"{:.0f}\" "
        "height=\"{:.0f}\" viewBox=\"0 0 {:.0f} {:.0f}\" data-from-ms=\"{}\" data-to-ms=\"{}\" "
        "data-left=\"{:.0f}\" data-px-per-ms=\"{:.9g}\" "
        "font-family=\"DejaVu Sans, Arial, Helvetica, sans-serif\" font-size=\"10\">\n",
        l_.total_width(), y, l_.total_width(), y, ms6(w_.from), ms6(w_.to), kLeft, l_.px_per_ms);
    out += "<title>" + html_escape(w_.title) + "</title>\n";
    out +=
        "<defs><pattern id=\"red-hatch\" width=\"6\" height=\"6\" patternUnits=\"userSpaceOnUse\" "
        "patternTransform=\"rotate(45)\"><rect width=\"6\" height=\"6\" fill=\"#fff3c4\"/>"
        "<line x1=\"0\" y1=\"0\" x2=\"0\" y2=\"6\" stroke=\"#c9a227\" stroke-width=\"2.5\"/>"
        "</pattern></defs>\n";
    out += fmt::format("<rect width=\"{:.0f}\" height=\"{:.0f}\" fill=\"#ffffff\"/>\n",
                       l_.total_width(), y);
    out += body;
    out += "</svg>\n";
    return out;
  }

 private:
  // The key: one swatch per operation and the marks.
  std::string legend(double y) const {
    std::string out = "<g class=\"legend\">\n";
    double x = 8;
    out += fmt::format(
        "<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"12\" font-weight=\"bold\">{}</text>\n", x,
        y + 14, html_escape(w_.title));
    y += 22;
    for (int op = 0; op < ops_; ++op) {
      const std::string& name = s_.operation_name(op);
      out += fmt::format(
          "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"14\" height=\"12\" fill=\"{}\" "
          "stroke=\"#555\" stroke-width=\"0.5\"/><text x=\"{:.1f}\" y=\"{:.1f}\">{}</text>\n",
          x, y, op_color(op), x + 18, y + 10, html_escape(name));
      x += 30 + kCharW * static_cast<double>(glyphs(name));
    }
    x += 10;
    auto key = [&](const std::string& mark, const std::string& text) {
      out += mark + fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\">{}</text>\n", x + 18, y + 10,
                                html_escape(text));
      x += 34 + kCharW * static_cast<double>(glyphs(text));
    };
    key(fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"3\" height=\"14\" fill=\"#222\"/>",
                    x + 6, y - 1),
        "round trip before a unit");
    key(fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"14\" height=\"12\" "
                    "fill=\"url(#red-hatch)\" stroke=\"#c9a227\"/>",
                    x, y),
        "merge wait");
    key(fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"14\" height=\"6\" fill=\"#999\" "
                    "opacity=\"0.35\"/><rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"9\" height=\"2\" "
                    "fill=\"#333\"/>",
                    x, y + 3, x, y + 5),
        "job: release to deadline, response over it");
    key(cross(x + 7, y + 6, "key"), "miss (late or no result)");
    key(fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" "
                    "stroke=\"#444\" stroke-dasharray=\"4,3\"/>",
                    x + 7, y - 2, x + 7, y + 14),
        "workload event");
    return out + "</g>\n";
  }

  static std::string cross(double x, double y, const char* cls) {
    return fmt::format(
        "<path class=\"{}\" d=\"M{:.2f},{:.2f}L{:.2f},{:.2f}M{:.2f},{:.2f}L{:.2f},{:.2f}\" "
        "stroke=\"#d00000\" stroke-width=\"2\"/>",
        cls, x - 4, y - 4, x + 4, y + 4, x - 4, y + 4, x + 4, y - 4);
  }

  // Tick labels (top or bottom of the whole drawing).
  std::string axis(double y, bool top) const {
    const double ms = to_ms(l_.to - l_.from);
    const double step = nice_step_ms(100.0 / l_.px_per_ms);  // a label every ≥ 100 px
    std::string out = "<g class=\"axis\">\n";
    const double first = std::ceil(to_ms(l_.from) / step) * step;
    const int decimals = step >= 1000 ? 0 : step >= 100 ? 1 : step >= 10 ? 2 : 3;
    for (double t = first; t <= to_ms(l_.from) + ms + 1e-9; t += step) {
      const double x = kLeft + (t - to_ms(l_.from)) * l_.px_per_ms;
      out += fmt::format(
          "<line x1=\"{:.2f}\" y1=\"{:.1f}\" x2=\"{:.2f}\" y2=\"{:.1f}\" stroke=\"#555\"/>"
          "<text x=\"{:.2f}\" y=\"{:.1f}\" text-anchor=\"middle\">{:.{}f} s</text>\n",
          x, top ? y + kAxisH - 6 : y, x, top ? y + kAxisH : y + 6, x, top ? y + 11 : y + 17,
          t / 1000.0, decimals);
    }
    return out + "</g>\n";
  }

  // Vertical grid lines, workload events and the warm-up over [y0, y1).
  std::string background(double y0, double y1) const {
    std::string out;
    const double step = nice_step_ms(100.0 / l_.px_per_ms);
    for (double t = std::ceil(to_ms(l_.from) / step) * step; t <= to_ms(l_.to) + 1e-9; t += step) {
      const double x = kLeft + (t - to_ms(l_.from)) * l_.px_per_ms;
      out += fmt::format(
          "<line x1=\"{:.2f}\" y1=\"{:.1f}\" x2=\"{:.2f}\" y2=\"{:.1f}\" stroke=\"#e4e4e4\"/>\n", x,
          y0, x, y1);
    }
    if (l_.from < s_.warmup) {
      const double x1 = l_.x(s_.warmup);
      out += fmt::format(
          "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#eeeeee\"/>"
          "<text x=\"{:.1f}\" y=\"{:.1f}\" fill=\"#777\">warm-up (not recorded)</text>\n",
          kLeft, y0, x1 - kLeft, y1 - y0, kLeft + 4, y0 + 12);
    }
    return out;
  }

  // The label of each workload event in the window, drawn in the policy's title row just right of
  // the event's line: [x0, x1) is where its (bold) text lies.
  struct EventLabel {
    std::size_t event = 0;
    double line_x = 0;
    std::string text;
    double x0 = 0, x1 = 0;
  };
  [[nodiscard]] std::vector<EventLabel> event_labels() const {
    std::vector<EventLabel> out;
    for (std::size_t i = 0; i < s_.events.size(); ++i) {
      const TimePoint at = s_.events[i].at;
      if (at < l_.from || at > l_.to) continue;
      EventLabel e;
      e.event = i;
      e.line_x = l_.x(at);
      e.text = fmt::format("event {}: {}", i, s_.events[i].kind);
      e.x0 = e.line_x + 4;
      e.x1 = e.x0 + kBoldW * kCharW * static_cast<double>(glyphs(e.text));
      out.push_back(std::move(e));
    }
    return out;
  }

  // Where the title row's "N jobs released" text starts: at kLeft, else past every event label
  // it would run into (an event at the window's start puts its label there), so none overlap.
  [[nodiscard]] static double free_x(const std::vector<EventLabel>& labels, double width) {
    std::vector<std::pair<double, double>> spans;
    for (const EventLabel& e : labels) spans.emplace_back(e.x0, e.x1);
    std::sort(spans.begin(), spans.end());
    double x = kLeft;
    for (const auto& [x0, x1] : spans)
      if (x0 < x + width + kLabelGap && x1 + kLabelGap > x) x = std::max(x, x1 + kLabelGap);
    return x;
  }

  std::string events(double y0, double y1) const {
    std::string out;
    for (const EventLabel& e : event_labels())
      out += fmt::format(
          "<g class=\"event\" data-event=\"{}\" data-at-ms=\"{}\"><line x1=\"{:.2f}\" "
          "y1=\"{:.1f}\" x2=\"{:.2f}\" y2=\"{:.1f}\" stroke=\"#444\" stroke-width=\"1.2\" "
          "stroke-dasharray=\"5,3\"/><text x=\"{:.2f}\" y=\"{:.1f}\" fill=\"#222\" "
          "font-weight=\"bold\">{}</text></g>\n",
          e.event, ms6(s_.events[e.event].at), e.line_x, y0 - kPolicyTitleH + 4, e.line_x, y1, e.x0,
          y0 - 7, html_escape(e.text));
    return out;
  }

  std::string policy_block(const TimelineRun& r, double& y) {
    std::string out =
        fmt::format("<g class=\"policy\" data-policy=\"{}\">\n", html_escape(r.policy));
    // Title with what happened in the window.
    std::int64_t jobs = 0, misses = 0;
    if (r.jobs != nullptr)
      for (const JobRow& j : *r.jobs) {
        if (j.release < l_.from || j.release >= l_.to) continue;
        ++jobs;
        if (j.outcome != JobOutcome::Met && j.outcome != JobOutcome::Unfinished) ++misses;
      }
    const std::string released =
        fmt::format("{} jobs released in this window, {} missed", jobs, misses);
    out += fmt::format(
        "<rect x=\"0\" y=\"{:.1f}\" width=\"{:.0f}\" height=\"{:.1f}\" fill=\"#f0f0f0\"/>"
        "<text x=\"8\" y=\"{:.1f}\" font-size=\"13\" font-weight=\"bold\">{}</text>"
        "<text class=\"released\" x=\"{:.1f}\" y=\"{:.1f}\" fill=\"#444\">{}</text>\n",
        y, l_.total_width(), kPolicyTitleH, y + 16, html_escape(r.policy),
        free_x(event_labels(), kCharW * static_cast<double>(glyphs(released))), y + 16, released);
    // The name again every 1200 px, for a reader scrolled far to the right.
    for (double x = kLeft + 1200; x + 200 < l_.total_width(); x += 1200)
      out += fmt::format(
          "<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"13\" font-weight=\"bold\" "
          "fill=\"#555\">{}</text>\n",
          x, y + 16, html_escape(r.policy));
    y += kPolicyTitleH;
    const double top = y;
    const int lanes = std::max(1, s_.device.lanes);
    const bool waits = r.waits != nullptr && !r.waits->empty();
    const double rows_h = lanes * kLaneH + (waits ? kWaitH : 0) + ops_ * kOpH;
    out += background(top, top + rows_h);
    for (int lane = 0; lane < lanes; ++lane) {
      out += lane_row(r, lane, y);
      y += kLaneH;
    }
    if (waits) {
      out += wait_row(r, y);
      y += kWaitH;
    }
    for (int op = 0; op < ops_; ++op) {
      out += op_row(r, op, y);
      y += kOpH;
    }
    out += events(top, y);
    if (r.waits == nullptr || r.waits_cut)
      out += fmt::format(
          "<text x=\"{:.1f}\" y=\"{:.1f}\" fill=\"#777\" font-style=\"italic\">{}</text>\n",
          kLeft + 4, y + 11,
          r.waits == nullptr ? "merge waits not recorded (no trace.json)"
                             : fmt::format("merge waits recorded until {:.3f} s (trace.json cut)",
                                           to_s(*r.waits_cut)));
    if (r.waits == nullptr || r.waits_cut) y += 14;
    return out + "</g>\n";
  }

  std::string lane_row(const TimelineRun& r, int lane, double y) const {
    std::string out = fmt::format(
        "<g class=\"lane\" data-lane=\"{}\"><rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" "
        "height=\"{:.1f}\" fill=\"#f7f7f7\" stroke=\"#dddddd\" stroke-width=\"0.5\"/>"
        "<text x=\"8\" y=\"{:.1f}\">lane {}</text>\n",
        lane, kLeft, y, l_.width, kLaneH, y + kLaneH / 2 + 4, lane);
    // Units on this lane in the window, by start time.
    std::vector<const UnitRow*> units;
    if (r.units != nullptr)
      for (const UnitRow& u : *r.units)
        if (u.lane == lane && u.start < l_.to && u.end > l_.from) units.push_back(&u);
    std::stable_sort(units.begin(), units.end(),
                     [](const UnitRow* a, const UnitRow* b) { return a->start < b->start; });
    // Idle gaps wide enough to say so.
    TimePoint busy_until = l_.from;
    for (const UnitRow* u : units) {
      const TimePoint gap_end = u->round_trip ? std::min(u->decided, u->start) : u->start;
      out += idle(busy_until, gap_end, y);
      busy_until = std::max(busy_until, u->end);
    }
    const TimePoint last = r.end < l_.to ? std::max(r.end, busy_until) : l_.to;
    out += idle(busy_until, last, y);
    for (const UnitRow* u : units) out += unit_box(r.policy, *u, y);
    return out + "</g>\n";
  }

  std::string idle(TimePoint from, TimePoint to, double y) const {
    if (to <= from) return {};
    const double x0 = l_.x(from), x1 = l_.x(to);
    const std::string text = fmt::format("idle {:.1f} ms", to_ms(to - from));
    if (x1 - x0 < kCharW * static_cast<double>(glyphs(text)) + 8) return {};
    return fmt::format(
        "<text class=\"idle\" x=\"{:.2f}\" y=\"{:.1f}\" text-anchor=\"middle\" fill=\"#999\" "
        "font-size=\"9\">{}</text>\n",
        (x0 + x1) / 2, y + kLaneH / 2 + 3, text);
  }

  std::string unit_box(const std::string& policy, const UnitRow& u, double y) const {
    const std::vector<MemberRef> members = parse_members(u.jobs);
    // The operations it served, in scenario order: one band of colour each.
    std::vector<int> ops;
    for (const MemberRef& m : members)
      for (int op = 0; op < ops_; ++op)
        if (s_.operation_name(op) == m.operation &&
            std::find(ops.begin(), ops.end(), op) == ops.end())
          ops.push_back(op);
    std::sort(ops.begin(), ops.end());
    if (ops.empty()) ops.push_back(-1);
    const double x0 = l_.x(u.start), x1 = std::max(l_.x(u.end), x0 + 1.0);
    const double bh = kLaneH - 8, by = y + 4;
    const std::string label = unit_label(s_, u, members);
    std::string tip = fmt::format(
        "{} dispatch {} on lane {}: {}\n{:.3f} to {:.3f} ms ({:.3f} ms), decided at {:.3f} ms{}\n"
        "batch {}, {} member{}, status {}",
        policy, u.dispatch, u.lane, label, to_ms(u.start), to_ms(u.end), to_ms(u.end - u.start),
        to_ms(u.decided), u.round_trip ? ", after a round trip" : ", back to back", u.batch,
        u.members, u.members == 1 ? "" : "s", to_string(u.status));
    for (const MemberRef& m : members)
      tip += fmt::format("\n  {}#{}{}{}", m.operation, m.job, m.node.empty() ? "" : ":", m.node);
    std::string out = fmt::format(
        "<g class=\"unit\" data-policy=\"{}\" data-dispatch=\"{}\" data-lane=\"{}\" "
        "data-start-ms=\"{}\" data-end-ms=\"{}\" data-kind=\"{}\" data-members=\"{}\" "
        "data-round-trip=\"{}\"><title>{}</title>",
        html_escape(policy), u.dispatch, u.lane, ms6(u.start), ms6(u.end), to_string(u.kind),
        u.members, u.round_trip ? 1 : 0, html_escape(tip));
    if (u.round_trip && u.start >= l_.from) {
      // The round trip to the synchronizer: a dark mark from the decision to the start,
      // at least wide enough to see.
      const double rx = std::min(l_.x(u.decided), x0 - 2.0);
      out += fmt::format(
          "<rect class=\"round-trip\" x=\"{:.2f}\" y=\"{:.1f}\" width=\"{:.2f}\" "
          "height=\"{:.1f}\" fill=\"#222\"/>",
          std::max(kLeft, rx), y + 1, std::max(1.5, x0 - rx), kLaneH - 2);
    }
    const double band = bh / static_cast<double>(ops.size());
    for (std::size_t i = 0; i < ops.size(); ++i)
      out += fmt::format(
          "<rect x=\"{:.2f}\" y=\"{:.2f}\" width=\"{:.2f}\" height=\"{:.2f}\" fill=\"{}\"/>", x0,
          by + band * static_cast<double>(i), x1 - x0, band, op_color(ops[i]));
    // Failed, out-of-memory and cancelled units: a red dashed outline; a unit cut by the
    // end of the run (unfinished): a grey dotted one.
    const bool cut = u.status == UnitStatus::Unfinished;
    const bool bad = u.status != UnitStatus::Completed && !cut;
    out += fmt::format(
        "<rect x=\"{:.2f}\" y=\"{:.1f}\" width=\"{:.2f}\" height=\"{:.1f}\" fill=\"none\" "
        "stroke=\"{}\" stroke-width=\"{}\"{}/>",
        x0, by, x1 - x0, bh,
        bad   ? "#d00000"
        : cut ? "#777"
              : "#333",
        bad || cut ? "1.5" : "0.6",
        bad   ? " stroke-dasharray=\"3,2\""
        : cut ? " stroke-dasharray=\"1,2\""
              : "");
    // The label if it fits: the node (kind or head) with ×N for merged runs and batches,
    // else shorter forms of it.
    const std::vector<std::string> forms = label_forms(s_, u, label);
    if (const std::string* fit = fitting_label(forms, x1 - x0))
      out += fmt::format("<text x=\"{:.2f}\" y=\"{:.1f}\" text-anchor=\"middle\">{}</text>",
                         (x0 + x1) / 2, by + bh / 2 + 3.5, html_escape(*fit));
    return out + "</g>\n";
  }

  std::string wait_row(const TimelineRun& r, double y) const {
    std::string out = fmt::format(
        "<g class=\"waits\"><text x=\"8\" y=\"{:.1f}\">merge waits</text>\n", y + kWaitH / 2 + 4);
    for (const TimelineWait& w : *r.waits) {
      if (w.until <= l_.from || w.at >= l_.to) continue;
      const double x0 = l_.x(w.at), x1 = std::max(l_.x(w.until), x0 + 1.5);
      const std::string sensor =
          w.sensor >= 0 && static_cast<std::size_t>(w.sensor) < s_.sensors.size()
              ? s_.sensors[static_cast<std::size_t>(w.sensor)].name
              : std::string("?");
      out += fmt::format(
          "<rect class=\"merge-wait\" x=\"{:.2f}\" y=\"{:.1f}\" width=\"{:.2f}\" height=\"{:.1f}\" "
          "fill=\"url(#red-hatch)\" stroke=\"#c9a227\" stroke-width=\"0.6\"><title>merge wait: the "
          "{} encoder run held from {:.3f} to {:.3f} ms for a predicted release</title></rect>\n",
          x0, y + 2, x1 - x0, kWaitH - 4, html_escape(sensor), to_ms(w.at), to_ms(w.until));
    }
    return out + "</g>\n";
  }

  // One operation's jobs: each on one of three sub-rows (by release index), a light bar
  // from release to deadline and a dark line from release to finish; a red cross on a miss.
  std::string op_row(const TimelineRun& r, int op, double y) const {
    std::string out = fmt::format(
        "<g class=\"operation\" data-operation=\"{}\"><rect x=\"{:.1f}\" y=\"{:.1f}\" "
        "width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#fcfcfc\" stroke=\"#e8e8e8\" "
        "stroke-width=\"0.5\"/><rect x=\"4\" y=\"{:.1f}\" width=\"10\" height=\"10\" "
        "fill=\"{}\"/><text x=\"18\" y=\"{:.1f}\">{}</text>\n",
        html_escape(s_.operation_name(op)), kLeft, y, l_.width, kOpH, y + kOpH / 2 - 5,
        op_color(op), y + kOpH / 2 + 4, html_escape(s_.operation_name(op)));
    if (r.jobs == nullptr) return out + "</g>\n";
    for (const JobRow& j : *r.jobs) {
      if (j.operation != op) continue;
      const bool done = j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed;
      const TimePoint last = std::max(j.deadline, j.finish);
      if (last < l_.from || j.release >= l_.to) continue;
      const double sub = y + 8 + 12.0 * static_cast<double>(j.seq % 3);
      const double xr = l_.x(j.release), xd = l_.x(j.deadline);
      const bool miss = j.outcome != JobOutcome::Met && j.outcome != JobOutcome::Unfinished;
      std::string tip = fmt::format("{} {}#{}: {}\nreleased {:.3f} ms, deadline {:.3f} ms",
                                    r.policy, s_.operation_name(op), j.seq, to_string(j.outcome),
                                    to_ms(j.release), to_ms(j.deadline));
      if (done)
        tip += fmt::format(", finished {:.3f} ms (response {:.3f} ms)", to_ms(j.finish),
                           to_ms(j.finish - j.release));
      else if (j.outcome != JobOutcome::Unfinished)
        tip += fmt::format(", ended {:.3f} ms", to_ms(j.finish));
      if (!j.reason.empty()) tip += "\nreason: " + j.reason;
      out += fmt::format(
          "<g class=\"job\" data-job=\"{}\" data-outcome=\"{}\" data-release-ms=\"{}\" "
          "data-deadline-ms=\"{}\"><title>{}</title>",
          j.seq, to_string(j.outcome), ms6(j.release), ms6(j.deadline), html_escape(tip));
      // Release tick, the budget up to the deadline, the deadline tick.
      out += fmt::format(
          "<rect x=\"{:.2f}\" y=\"{:.1f}\" width=\"{:.2f}\" height=\"7\" fill=\"{}\" "
          "opacity=\"0.45\"/><line x1=\"{:.2f}\" y1=\"{:.1f}\" x2=\"{:.2f}\" y2=\"{:.1f}\" "
          "stroke=\"#333\" stroke-width=\"1\"/><line class=\"deadline\" x1=\"{:.2f}\" "
          "y1=\"{:.1f}\" x2=\"{:.2f}\" y2=\"{:.1f}\" stroke=\"#333\" stroke-width=\"1.5\"/>",
          xr, sub - 3.5, std::max(0.0, xd - xr), op_color(op), xr, sub - 5, xr, sub + 5, xd,
          sub - 5, xd, sub + 5);
      if (done)
        out += fmt::format(
            "<line x1=\"{:.2f}\" y1=\"{:.1f}\" x2=\"{:.2f}\" y2=\"{:.1f}\" stroke=\"{}\" "
            "stroke-width=\"2\"/>",
            xr, sub, std::max(l_.x(j.finish), xr + 1), sub,
            j.outcome == JobOutcome::Met ? "#222" : "#d00000");
      if (miss && j.finish >= l_.from && j.finish <= l_.to)
        out += cross(l_.x(j.finish), sub, "miss");
      out += "</g>\n";
    }
    return out + "</g>\n";
  }

  const Scenario& s_;
  const TimelineWindow& w_;
  Layout l_;
  int ops_ = 0;
};

}  // namespace

std::string timeline_svg(const Scenario& s, const std::vector<TimelineRun>& runs,
                         const TimelineWindow& window) {
  SvgWriter w(s, window);
  return w.render(runs);
}

}  // namespace red
