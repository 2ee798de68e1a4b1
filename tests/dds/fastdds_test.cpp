// Interoperability with eProsima Fast DDS (docs/ROS2.md): a Fast DDS program built with fastddsgen
// from RED's IDL -- what a ROS 2 Humble user's nodes run on by default -- publishes camera
// frames to `red node` over RTPS/UDP on loopback and receives every output type, each with
// the stamp of a frame it sent, and the diagnostics.

#include <gtest/gtest.h>

#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "../support/cli.hpp"
#include "support.hpp"

namespace red::dds {
namespace {

TEST(DdsNodeFastDds, AFastDdsPeerExchangesEveryTypeWithTheNode) {
#ifndef RED_FASTDDS_PEER
  GTEST_SKIP() << "built without Fast DDS (apt-get install libfastrtps-dev fastddsgen)";
#else
  const std::string d = std::to_string(test_domain());
  const std::string err = ::testing::TempDir() + "fastdds_node.err";
  const std::string out = ::testing::TempDir() + "fastdds_peer.json";
  int node_code = -1;
  std::thread node([&] {
    node_code = std::system((std::string(RED_CLI) +
                             " node '" RED_SOURCE_DIR
                             "/tests/dds/data/node.yaml' --backend synthetic --duration 6 "
                             "--domain " +
                             d + " 2> '" + err + "'")
                                .c_str());
  });
  const int peer =
      std::system((std::string(RED_FASTDDS_PEER) + " " + d + " 40 20 2 > '" + out + "'").c_str());
  node.join();
  EXPECT_EQ(peer, 0);
  EXPECT_EQ(node_code, 0) << test::read_text(err);
  const auto r = nlohmann::json::parse(test::read_text(out), nullptr, false);
  ASSERT_FALSE(r.is_discarded()) << test::read_text(out);
  ASSERT_TRUE(r["matched"].get<bool>()) << "red node's reader never matched the Fast DDS writer\n"
                                        << test::read_text(err);
  EXPECT_EQ(r["sent"], 40);
  for (const std::string t :
       {"/red/drive/L", "/red/drive/S", "/red/drive/C/stamped", "/red/detect/O"}) {
    SCOPED_TRACE(t);
    const auto& o = r["outputs"][t];
    EXPECT_GT(o["count"].get<int>(), 0) << r.dump();
    // Every output carries the header of a frame the Fast DDS peer sent.
    EXPECT_EQ(o["matched_stamps"], o["count"]) << r.dump();
  }
  EXPECT_GT(r["outputs"]["/red/drive/C"]["count"].get<int>(), 0) << r.dump();
  EXPECT_GT(r["diagnostics"].get<int>(), 0);
  EXPECT_GT(std::stoi(r["diagnostic_values"]["red: node/frames"].get<std::string>()), 0);
  EXPECT_EQ(r["diagnostic_values"]["red: node/rejected_unknown_encoding"], "0");
#endif
}

}  // namespace
}  // namespace red::dds
