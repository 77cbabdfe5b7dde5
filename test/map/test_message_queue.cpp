// The queue between the SLAM threads: FIFO order, urgent items first (in their own order),
// non-blocking tryPop, waitPop wakes on push and ends after close(), and items from a producer
// thread all arrive in order.

#include <thread>

#include <gtest/gtest.h>

#include "scale_drift_slam/map/keyframe_message.h"
#include "scale_drift_slam/map/message_queue.h"

namespace scale_drift_slam::map {
namespace {

TEST(MessageQueue, KeepsOrderAndNeverBlocksOnTryPop) {
  MessageQueue<int> queue;
  EXPECT_FALSE(queue.tryPop().has_value());
  queue.push(1);
  queue.push(2);
  EXPECT_EQ(queue.size(), 2u);
  EXPECT_EQ(*queue.tryPop(), 1);
  EXPECT_EQ(*queue.tryPop(), 2);
  queue.close();
  EXPECT_FALSE(queue.push(3));
  EXPECT_FALSE(queue.waitPop().has_value());
}

TEST(MessageQueue, UrgentItemsOvertakeOrdinaryOnesInTheirOwnOrder) {
  MessageQueue<int> queue;
  queue.push(1);
  queue.push(2);
  queue.pushUrgent(10);
  queue.push(3);
  queue.pushUrgent(11);
  EXPECT_EQ(*queue.tryPop(), 10);
  queue.pushUrgent(12);  // behind 11, which was urgent before it
  EXPECT_EQ(*queue.waitPop(), 11);
  EXPECT_EQ(*queue.tryPop(), 12);
  EXPECT_EQ(*queue.tryPop(), 1);
  queue.pushUrgent(13);
  EXPECT_EQ(*queue.tryPop(), 13);
  EXPECT_EQ(*queue.tryPop(), 2);
  EXPECT_EQ(*queue.tryPop(), 3);
  EXPECT_FALSE(queue.tryPop().has_value());
  queue.close();
  EXPECT_FALSE(queue.pushUrgent(14));
}

TEST(MessageQueue, CarriesMessagesAcrossThreadsInOrder) {
  MessageQueue<KeyframeMessage> queue;
  std::thread producer([&] {
    for (KeyframeId id = 0; id < 200; ++id) {
      KeyframeMessage message;
      message.keyframe.id = id;
      queue.push(std::move(message));
    }
    queue.close();
  });
  KeyframeId expected = 0;
  while (auto message = queue.waitPop())
    EXPECT_EQ(message->keyframe.id, expected++);
  producer.join();
  EXPECT_EQ(expected, 200u);
}

}  // namespace
}  // namespace scale_drift_slam::map
