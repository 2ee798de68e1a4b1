#pragma once
/// \file
/// Raw CDR of a message type as Cyclone DDS puts it on the wire (encapsulation header
/// included), and back: for tests and tools that compare bytes with another serializer.

#include <dds/dds.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "red/core/expected.hpp"

namespace red::dds {

/// Serializes and deserializes samples of one type through Cyclone's own serdata (the
/// code that writes them on the wire), using a local writer and reader on `participant`.
class CdrCodec {
 public:
  /// Error when the topic or endpoints cannot be created.
  static Expected<std::unique_ptr<CdrCodec>> make(dds_entity_t participant,
                                                  const dds_topic_descriptor_t* desc);
  ~CdrCodec();
  CdrCodec(const CdrCodec&) = delete;
  CdrCodec& operator=(const CdrCodec&) = delete;

  /// The serialized bytes of `sample` (XCDR1, with the 4-byte encapsulation header).
  Expected<std::vector<std::uint8_t>> serialize(const void* sample);
  /// Decodes `bytes` into `sample` (zeroed; free it with dds_sample_free(..., DDS_FREE_CONTENTS)).
  Expected<bool> deserialize(const std::vector<std::uint8_t>& bytes, void* sample);

 private:
  CdrCodec(dds_entity_t topic, dds_entity_t writer, dds_entity_t reader)
      : topic_(topic), writer_(writer), reader_(reader) {}
  dds_entity_t topic_;
  dds_entity_t writer_;
  dds_entity_t reader_;
  const struct ddsi_sertype* type_ = nullptr;  // from the first serialized sample
};

}  // namespace red::dds
