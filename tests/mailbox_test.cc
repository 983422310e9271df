// LatestMailbox: the one-slot latest-frame queue between the LCM thread and the scheduler.
#include "service/mailbox.h"

#include <gtest/gtest.h>

#include <string>
#include <thread>

namespace g6d {
namespace {

using Mailbox = LatestMailbox<std::string>;

TEST(LatestMailbox, NewerItemReplacesTheWaitingOne) {
  Mailbox mailbox;
  EXPECT_FALSE(mailbox.Full());
  EXPECT_EQ(mailbox.Put("a"), Mailbox::PutResult::kStored);
  EXPECT_TRUE(mailbox.Full());
  EXPECT_EQ(mailbox.Put("b"), Mailbox::PutResult::kReplaced);
  EXPECT_EQ(mailbox.Put("c"), Mailbox::PutResult::kReplaced);
  EXPECT_EQ(mailbox.Take().value(), "c");
  EXPECT_FALSE(mailbox.Full());
  EXPECT_EQ(mailbox.Put("d"), Mailbox::PutResult::kStored);
  EXPECT_EQ(mailbox.Take().value(), "d");
}

TEST(LatestMailbox, TakeBlocksUntilAPut) {
  Mailbox mailbox;
  std::string taken;
  std::thread consumer([&] { taken = mailbox.Take().value_or("nothing"); });
  mailbox.Put("frame");
  consumer.join();
  EXPECT_EQ(taken, "frame");
}

TEST(LatestMailbox, StopWakesAWaitingConsumerAndRefusesItems) {
  Mailbox mailbox;
  bool got_nothing = false;
  std::thread consumer([&] { got_nothing = !mailbox.Take().has_value(); });
  EXPECT_FALSE(mailbox.Stop());  // nothing discarded
  consumer.join();
  EXPECT_TRUE(got_nothing);
  EXPECT_EQ(mailbox.Put("late"), Mailbox::PutResult::kStopped);
  EXPECT_FALSE(mailbox.Take().has_value());
}

TEST(LatestMailbox, StopDiscardsTheWaitingItem) {
  Mailbox mailbox;
  mailbox.Put("pending");
  EXPECT_TRUE(mailbox.Stop());
  EXPECT_FALSE(mailbox.Take().has_value());
  EXPECT_FALSE(mailbox.Stop());  // idempotent
}

TEST(LatestMailbox, ProducerAndConsumerThreadsLoseNothingButReplacedItems) {
  Mailbox mailbox;
  constexpr int kItems = 20000;
  int replaced = 0, taken = 0;
  std::string last;
  std::thread consumer([&] {
    while (auto item = mailbox.Take()) {
      ++taken;
      last = *item;
    }
  });
  for (int i = 0; i < kItems; ++i) {
    if (mailbox.Put(std::to_string(i)) == Mailbox::PutResult::kReplaced) ++replaced;
  }
  // Every item was either taken, replaced, or is the one Stop() discards.
  const bool discarded = mailbox.Stop();
  consumer.join();
  EXPECT_EQ(taken + replaced + (discarded ? 1 : 0), kItems);
  if (!discarded) {
    EXPECT_EQ(last, std::to_string(kItems - 1));
  }
}

}  // namespace
}  // namespace g6d
