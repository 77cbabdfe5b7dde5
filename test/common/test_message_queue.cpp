// The queue between the SLAM threads: FIFO order, urgent items first (in their own order),
// non-blocking tryPop, waitPop wakes on push and ends after close(), and items from a producer
// thread all arrive in order.

#include <cstdint>
#include <memory>
#include <thread>

#include <gtest/gtest.h>

#include "scale_drift_slam/common/message_queue.h"

namespace scale_drift_slam::common {
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

/// A message that can only be moved, as the keyframes the queues carry.
struct NumberedMessage {
  std::uint64_t id = 0;
  std::unique_ptr<int> payload;
};

TEST(MessageQueue, CarriesMessagesAcrossThreadsInOrder) {
  MessageQueue<NumberedMessage> queue;
  std::thread producer([&] {
    for (std::uint64_t id = 0; id < 200; ++id) {
      NumberedMessage message;
      message.id = id;
      message.payload = std::make_unique<int>(static_cast<int>(id));
      queue.push(std::move(message));
    }
    queue.close();
  });
  std::uint64_t expected = 0;
  while (auto message = queue.waitPop()) {
    ASSERT_TRUE(message->payload);
    EXPECT_EQ(*message->payload, static_cast<int>(expected));
    EXPECT_EQ(message->id, expected++);
  }
  producer.join();
  EXPECT_EQ(expected, 200u);
}

}  // namespace
}  // namespace scale_drift_slam::common
