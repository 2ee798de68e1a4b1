// Writes the seed corpus of fuzz_dds (tests/fuzz/corpus/fuzz_dds/): one sample of every
// message type as Cyclone DDS serializes it from RED's types, each prefixed with the byte
// that selects its type in fuzz_dds, good images of every encoding and the node's bad ones.
// Usage: fuzz_dds_seeds DIR

#include <dds/dds.h>
#include <dds/ddsi/ddsi_cdrstream.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "red/dds/messages.hpp"

namespace {

using namespace red::dds;

std::string g_dir;

// Writes [type][encapsulation header][CDR of `sample`] to DIR/name.
void seed(const std::string& name, std::uint8_t type, const dds_topic_descriptor_t* desc,
          const void* sample, bool big_endian = false) {
  std::vector<std::uint8_t> bytes{type, 0, static_cast<std::uint8_t>(big_endian ? 0 : 1), 0, 0};
  if (big_endian) {
    dds_ostreamBE_t be;
    dds_ostreamBE_init(&be, 0, 1);
    dds_stream_writeBE(&be, static_cast<const char*>(sample), desc->m_ops);
    bytes.insert(bytes.end(), be.x.m_buffer, be.x.m_buffer + be.x.m_index);
    dds_ostreamBE_fini(&be);
  } else {
    dds_ostream_t os;
    dds_ostream_init(&os, 0, 1);
    dds_stream_write(&os, static_cast<const char*>(sample), desc->m_ops);
    bytes.insert(bytes.end(), os.m_buffer, os.m_buffer + os.m_index);
    dds_ostream_fini(&os);
  }
  std::ofstream(g_dir + "/" + name, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

void image(const std::string& name, const std::string& encoding, std::uint32_t w, std::uint32_t h,
           std::uint32_t step, std::size_t size, bool big_endian = false) {
  std::vector<std::uint8_t> data(size);
  for (std::size_t i = 0; i < size; ++i) data[i] = static_cast<std::uint8_t>(i * 37);
  const std::string frame = "camera";
  Image img{};
  img.header_.stamp_.sec_ = 1700000000;
  img.header_.stamp_.nanosec_ = 123456789;
  img.header_.frame_id_ = borrow(frame);
  img.height_ = h;
  img.width_ = w;
  img.encoding_ = borrow(encoding);
  img.step_ = step;
  borrow(img.data_, data);
  seed(name, 0, &sensor_msgs_msg_dds__Image__desc, &img, big_endian);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_dds_seeds DIR\n");
    return 2;
  }
  g_dir = argv[1];
  image("image_rgb8", "rgb8", 4, 3, 12, 36);
  image("image_bgr8_padded_rows", "bgr8", 3, 2, 12, 24);
  image("image_mono8", "mono8", 5, 4, 5, 20);
  image("image_rgb8_big_endian", "rgb8", 2, 2, 6, 12, true);
  image("bad_image_unknown_encoding", "yuv422", 4, 4, 8, 32);
  image("bad_image_data_size", "rgb8", 4, 4, 12, 47);
  image("bad_image_absurd_size", "mono8", 100000, 2, 100000, 16);
  image("bad_image_step", "rgb8", 8, 2, 8, 16);

  Twist t{};
  t.linear_.x_ = 0.5;
  t.angular_.z_ = -0.25;
  seed("twist", 1, &geometry_msgs_msg_dds__Twist__desc, &t);
  const std::string frame = "camera";
  TwistStamped ts{};
  ts.header_.stamp_.sec_ = 1700000000;
  ts.header_.frame_id_ = borrow(frame);
  ts.twist_ = t;
  seed("twist_stamped", 2, &geometry_msgs_msg_dds__TwistStamped__desc, &ts);

  const std::string cls = "bright", id = "d1";
  std::vector<ObjectHypothesisWithPose> hyp(1);
  hyp[0].hypothesis_.class_id_ = borrow(cls);
  hyp[0].hypothesis_.score_ = 0.75;
  hyp[0].pose_.pose_.orientation_.w_ = 1.0;
  std::vector<Detection2D> dets(2);
  for (Detection2D& d : dets) {
    d.header_.frame_id_ = borrow(frame);
    borrow(d.results_, hyp);
    d.bbox_.size_x_ = 4;
    d.bbox_.size_y_ = 3;
    d.id_ = borrow(id);
  }
  Detection2DArray a{};
  a.header_.frame_id_ = borrow(frame);
  borrow(a.detections_, dets);
  seed("detections", 3, &vision_msgs_msg_dds__Detection2DArray__desc, &a);
  Detection2DArray empty{};
  empty.header_.frame_id_ = borrow(frame);
  seed("detections_empty", 3, &vision_msgs_msg_dds__Detection2DArray__desc, &empty);

  const std::string k1 = "jobs", v1 = "42", k2 = "miss_rate", v2 = "0.01", name = "red: drive",
                    msg = "ok", hw = "red";
  std::vector<KeyValue> kv{{borrow(k1), borrow(v1)}, {borrow(k2), borrow(v2)}};
  std::vector<DiagnosticStatus> status(1);
  status[0].level_ = 1;
  status[0].name_ = borrow(name);
  status[0].message_ = borrow(msg);
  status[0].hardware_id_ = borrow(hw);
  borrow(status[0].values_, kv);
  DiagnosticArray diag{};
  diag.header_.frame_id_ = borrow(frame);
  borrow(diag.status_, status);
  seed("diagnostics", 4, &diagnostic_msgs_msg_dds__DiagnosticArray__desc, &diag);
  return 0;
}
