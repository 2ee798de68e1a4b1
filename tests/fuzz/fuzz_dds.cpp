// libFuzzer target: a DDS sample as it arrives on the wire -> the decoding `red node` and
// its listeners run on it (docs/ROS2.md). Byte 0 picks the message type (Image, the one type the
// node subscribes to, and the types its subscribers decode: Twist, TwistStamped,
// Detection2DArray, DiagnosticArray); the rest is the serialized payload, a 4-byte
// encapsulation header then CDR. The payload goes through Cyclone DDS's own receive path
// for RED's idlc-generated types -- dds_stream_normalize_data (validation and byte-swap,
// what Cyclone runs on every received sample) and dds_stream_read (what dds_take runs) --
// and an Image then through the node's check_image, to_gray and to_rgb. Beyond "no crash,
// no leak, no sanitizer report": a decoded sample re-encodes to CDR that decodes and
// re-encodes to the same bytes.

#include <dds/dds.h>
#include <dds/ddsi/ddsi_cdrstream.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "fuzz_support.hpp"
#include "red/dds/image.hpp"
#include "red/dds/messages.hpp"

namespace {

const dds_topic_descriptor_t* const kTypes[] = {
    &sensor_msgs_msg_dds__Image__desc, &geometry_msgs_msg_dds__Twist__desc,
    &geometry_msgs_msg_dds__TwistStamped__desc, &vision_msgs_msg_dds__Detection2DArray__desc,
    &diagnostic_msgs_msg_dds__DiagnosticArray__desc};

constexpr bool kHostLittleEndian = DDSRT_ENDIAN == DDSRT_LITTLE_ENDIAN;

// A decoded sample of `desc`, freed with its contents.
struct Sample {
  const dds_topic_descriptor_t* desc;
  void* p;
  explicit Sample(const dds_topic_descriptor_t* d) : desc(d), p(std::calloc(1, d->m_size)) {}
  ~Sample() {
    dds_stream_free_sample(p, desc->m_ops);
    std::free(p);
  }
  Sample(const Sample&) = delete;
  Sample& operator=(const Sample&) = delete;
};

// Validates `cdr` (CDR without the encapsulation header, `xcdr` 1 or 2) as `desc` and reads
// it into `out`, as Cyclone does for a received sample; false when it is not valid.
bool decode(const dds_topic_descriptor_t* desc, const std::uint8_t* cdr, std::size_t size,
            bool bswap, std::uint32_t xcdr, Sample& out) {
  if (size > 0xffff'ffffU) return false;
  // Cyclone keeps received data 8-byte aligned; normalize works in place.
  std::vector<std::uint64_t> buf((size + 7) / 8 + 1, 0);
  std::memcpy(buf.data(), cdr, size);
  std::uint32_t off = 0;
  const auto n = static_cast<std::uint32_t>(size);
  if (dds_stream_normalize_data(reinterpret_cast<char*>(buf.data()), &off, n, bswap, xcdr,
                                desc->m_ops) == nullptr)
    return false;
  dds_istream_t is;
  dds_istream_init(&is, n, buf.data(), xcdr);
  dds_stream_read(&is, static_cast<char*>(out.p), desc->m_ops);
  dds_istream_fini(&is);
  return true;
}

// The CDR (native byte order, no encapsulation header) of `sample`.
std::vector<std::uint8_t> encode(const dds_topic_descriptor_t* desc, const void* sample,
                                 std::uint32_t xcdr) {
  dds_ostream_t os;
  dds_ostream_init(&os, 0, xcdr);
  dds_stream_write(&os, static_cast<const char*>(sample), desc->m_ops);
  std::vector<std::uint8_t> bytes(os.m_buffer, os.m_buffer + os.m_index);
  dds_ostream_fini(&os);
  return bytes;
}

// What the node does with a received image: checks, then the model input and the frame
// its outputs are computed from, at a few sizes (the model's is any).
void use_image(const red::dds::Image& img) {
  if (red::dds::check_image(img)) return;
  red::dds::GrayFrame gray;
  std::vector<std::uint8_t> rgb;
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{7, 3}, std::pair{96, 48}}) {
    red::dds::to_gray(img, w, h, gray);
    red::dds::to_rgb(img, w, h, rgb);
    if (gray.pixels.size() != static_cast<std::size_t>(w * h) ||
        rgb.size() != static_cast<std::size_t>(w * h * 3))
      red::fuzz::fail("converted frame of the wrong size");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t kTypeCount = sizeof kTypes / sizeof kTypes[0];
  if (size < 5) return 0;
  const dds_topic_descriptor_t* desc = kTypes[data[0] % kTypeCount];
  // Encapsulation identifier (big-endian): CDR_BE 0, CDR_LE 1 (XCDR1, what ROS 2 sends);
  // CDR2_BE 6, CDR2_LE 7 (XCDR2 of a final type). Cyclone refuses any other for these types.
  const unsigned id = (static_cast<unsigned>(data[1]) << 8U) | data[2];
  if (id != 0 && id != 1 && id != 6 && id != 7) return 0;
  const bool little = (id & 1U) != 0;
  const std::uint32_t xcdr = id < 6 ? 1 : 2;
  const std::uint8_t* cdr = data + 5;  // after the type byte and the 4-byte header
  Sample s(desc);
  if (!decode(desc, cdr, size - 5, little != kHostLittleEndian, xcdr, s)) return 0;
  if (desc == &sensor_msgs_msg_dds__Image__desc)
    use_image(*static_cast<const red::dds::Image*>(s.p));
  const std::vector<std::uint8_t> once = encode(desc, s.p, xcdr);
  Sample again(desc);
  if (!decode(desc, once.data(), once.size(), false, xcdr, again))
    red::fuzz::fail("a decoded sample re-encodes to CDR that does not decode");
  if (encode(desc, again.p, xcdr) != once) red::fuzz::fail("CDR round trip differs");
  return 0;
}
