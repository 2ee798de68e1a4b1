#include "red/dds/cdr.hpp"

#include <dds/ddsi/ddsi_serdata.h>

#include <atomic>

namespace red::dds {

Expected<std::unique_ptr<CdrCodec>> CdrCodec::make(dds_entity_t participant,
                                                   const dds_topic_descriptor_t* desc) {
  static std::atomic<int> counter{0};
  // A topic name of its own, so a codec never sees another's samples.
  const std::string name =
      std::string("red_cdr_") + std::to_string(counter.fetch_add(1)) + "_" + desc->m_typename;
  std::string safe;
  for (char c : name) safe += (c == ':') ? '_' : c;
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(qos, 1, &xcdr1);
  const dds_entity_t topic = dds_create_topic(participant, desc, safe.c_str(), qos, nullptr);
  const dds_entity_t writer =
      topic < 0 ? topic : dds_create_writer(participant, topic, qos, nullptr);
  const dds_entity_t reader =
      writer < 0 ? writer : dds_create_reader(participant, topic, qos, nullptr);
  dds_delete_qos(qos);
  if (reader < 0) {
    if (topic > 0) dds_delete(topic);
    return Error{"", 0,
                 std::string("cannot create a CDR codec for ") + desc->m_typename + ": " +
                     dds_strretcode(reader)};
  }
  return std::unique_ptr<CdrCodec>(new CdrCodec(topic, writer, reader));
}

CdrCodec::~CdrCodec() {
  dds_delete(reader_);
  dds_delete(writer_);
  dds_delete(topic_);
}

Expected<std::vector<std::uint8_t>> CdrCodec::serialize(const void* sample) {
  if (const dds_return_t rc = dds_write(writer_, sample); rc < 0)
    return Error{"", 0, std::string("dds_write: ") + dds_strretcode(rc)};
  // A local reader gets the writer's serialized sample synchronously.
  struct ddsi_serdata* sd = nullptr;
  dds_sample_info_t info;
  const dds_return_t n = dds_takecdr(reader_, &sd, 1, &info, DDS_ANY_STATE);
  if (n != 1) return Error{"", 0, "dds_takecdr returned no sample"};
  if (type_ == nullptr) type_ = sd->type;
  std::vector<std::uint8_t> bytes(ddsi_serdata_size(sd));
  ddsi_serdata_to_ser(sd, 0, bytes.size(), bytes.data());
  ddsi_serdata_unref(sd);
  return bytes;
}

Expected<bool> CdrCodec::deserialize(const std::vector<std::uint8_t>& bytes, void* sample) {
  if (type_ == nullptr) return Error{"", 0, "deserialize before any serialize: no sertype yet"};
  ddsrt_iovec_t iov;
  iov.iov_base = const_cast<std::uint8_t*>(bytes.data());
  iov.iov_len = static_cast<ddsrt_iov_len_t>(bytes.size());
  struct ddsi_serdata* sd = ddsi_serdata_from_ser_iov(type_, SDK_DATA, 1, &iov, bytes.size());
  if (sd == nullptr) return Error{"", 0, "the bytes are not valid CDR of this type"};
  const bool ok = ddsi_serdata_to_sample(sd, sample, nullptr, nullptr);
  ddsi_serdata_unref(sd);
  if (!ok) return Error{"", 0, "the bytes do not decode as this type"};
  return true;
}

}  // namespace red::dds
