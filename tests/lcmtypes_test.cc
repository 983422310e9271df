// Round trips of the g6d LCM message types through encode/decode and through a real
// in-process LCM bus (memq).
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "g6d/pose_array_t.hpp"
#include "g6d/rgbd_frame_t.hpp"
#include "g6d/service_status_t.hpp"

namespace {

g6d::rgbd_frame_t MakeFrame() {
  g6d::rgbd_frame_t frame;
  frame.utime = 1234567;
  frame.seq = 42;
  frame.camera_id = "cam0";
  frame.source = "unit-test";
  frame.scene_id = 2;
  frame.image_id = 17;
  frame.fx = 572.4;
  frame.fy = 573.5;
  frame.cx = 325.2;
  frame.cy = 242.0;
  frame.depth_scale_m = 0.001;
  frame.color.width = 4;
  frame.color.height = 2;
  frame.color.row_stride = 12;
  frame.color.pixel_format = g6d::image_t::FORMAT_RGB8;
  frame.color.compression = g6d::image_t::COMPRESSION_NONE;
  frame.color.data.assign(24, 7);
  frame.color.size = 24;
  frame.depth = frame.color;
  frame.depth.pixel_format = g6d::image_t::FORMAT_DEPTH_U16;
  frame.labels = frame.color;
  frame.labels.pixel_format = g6d::image_t::FORMAT_LABEL_U8;
  g6d::instance_t instance;
  instance.object_id = "obj_000005";
  instance.label = 3;
  instance.score = 0.9f;
  instance.gt_index = 1;
  frame.instances.push_back(instance);
  frame.num_instances = 1;
  return frame;
}

TEST(RgbdFrame, EncodeDecodeRoundTrip) {
  const g6d::rgbd_frame_t frame = MakeFrame();
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  ASSERT_EQ(frame.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  g6d::rgbd_frame_t decoded;
  ASSERT_EQ(decoded.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  EXPECT_EQ(decoded.camera_id, "cam0");
  EXPECT_EQ(decoded.image_id, 17);
  EXPECT_EQ(decoded.color.data, frame.color.data);
  ASSERT_EQ(decoded.num_instances, 1);
  EXPECT_EQ(decoded.instances[0].object_id, "obj_000005");
  EXPECT_EQ(decoded.instances[0].label, 3);
}

TEST(RgbdFrame, DecodeRefusesOtherTypeAndTruncation) {
  const g6d::rgbd_frame_t frame = MakeFrame();
  std::vector<uint8_t> bytes(static_cast<size_t>(frame.getEncodedSize()));
  frame.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  g6d::pose_array_t wrong_type;
  EXPECT_LT(wrong_type.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0)
      << "the LCM fingerprint must reject a frame decoded as a pose array";
  g6d::rgbd_frame_t truncated;
  EXPECT_LT(truncated.decode(bytes.data(), 0, static_cast<int>(bytes.size()) - 5), 0);
}

class Receiver {
 public:
  void Handle(const lcm::ReceiveBuffer*, const std::string& channel,
              const g6d::service_status_t* status) {
    channels.push_back(channel);
    objects = status->objects;
  }
  std::vector<std::string> channels;
  std::vector<std::string> objects;
};

TEST(ServiceStatus, TravelsOverMemqBus) {
  lcm::LCM bus("memq://");
  ASSERT_TRUE(bus.good());
  Receiver receiver;
  bus.subscribe("G6D_STATUS_TEST", &Receiver::Handle, &receiver);
  g6d::service_status_t status{};
  status.service_name = "cam0";
  status.objects = {"obj_000001", "obj_000005"};
  status.num_objects = 2;
  ASSERT_EQ(bus.publish("G6D_STATUS_TEST", &status), 0);
  ASSERT_GT(bus.handleTimeout(1000), 0);
  ASSERT_EQ(receiver.channels.size(), 1u);
  EXPECT_EQ(receiver.objects, status.objects);
}

}  // namespace
