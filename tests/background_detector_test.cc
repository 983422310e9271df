// BackgroundDetector: the service's re-detection thread, on a synthetic frame rendered by
// the project's own renderer.
#include "service/background_detector.h"

#include <chrono>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "eval/metrics.h"
#include "mesh/mesh.h"
#include "synthetic_scene.h"
#include "test_bank.h"

namespace g6d {
namespace {

const Camera kCamera{572.4, 573.6, 325.3, 242.0, 640, 480};

class BackgroundDetectorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mesh_ = new Mesh(test::MakeTexturedBox(0.10, 0.07, 0.05, 21));
    ThreadPool pool(2);
    bank_ = std::make_shared<const TemplateBank>(
        test::SharedTestBank("box21-default", *mesh_, "box", TemplateBuildOptions(), &pool));
  }
  static void TearDownTestSuite() {
    bank_.reset();
    delete mesh_;
  }
  static BackgroundDetector::Job MakeJob(int track_id, Eigen::Isometry3d* truth) {
    truth->linear() = Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitX()).toRotationMatrix();
    truth->translation() = Eigen::Vector3d(0.0, 0.0, 0.7);
    GlRenderer renderer(*mesh_);
    const test::SyntheticView view = test::RenderSyntheticView(&renderer, *mesh_, kCamera, *truth, test::SyntheticOptions());
    BackgroundDetector::Job job;
    job.track_id = track_id;
    job.frame = Frame{kCamera, view.rgb, view.depth};
    job.instance = Instance{"box", view.mask};
    job.bank = bank_;
    job.tracked.success = true;
    job.tracked.cam_from_object = *truth;
    job.tracked.score = 0.1;
    return job;
  }
  static Mesh* mesh_;
  static std::shared_ptr<const TemplateBank> bank_;
};
Mesh* BackgroundDetectorTest::mesh_ = nullptr;
std::shared_ptr<const TemplateBank> BackgroundDetectorTest::bank_;

// Waits (up to five minutes: a wait, not a timing assertion; a full solve under
// ThreadSanitizer takes tens of seconds) for `count` finished jobs.
std::vector<BackgroundDetector::Done> WaitFor(BackgroundDetector* detector, size_t count) {
  std::vector<BackgroundDetector::Done> done;
  for (int i = 0; i < 30000 && done.size() < count; ++i) {
    for (BackgroundDetector::Done& d : detector->TakeFinished()) done.push_back(std::move(d));
    if (done.size() < count) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return done;
}

TEST_F(BackgroundDetectorTest, RunsTheFullSolverOnQueuedJobsInOrder) {
  BackgroundDetector detector(SolverOptions(), 4, 10);
  Eigen::Isometry3d truth;
  ASSERT_TRUE(detector.Submit(MakeJob(7, &truth)));
  ASSERT_TRUE(detector.Submit(MakeJob(8, &truth)));
  const std::vector<BackgroundDetector::Done> done = WaitFor(&detector, 2);
  ASSERT_EQ(done.size(), 2u);
  EXPECT_EQ(done[0].job.track_id, 7);
  EXPECT_EQ(done[1].job.track_id, 8);
  std::vector<Eigen::Vector3f> points(mesh_->vertices.begin(), mesh_->vertices.end());
  for (const BackgroundDetector::Done& d : done) {
    ASSERT_TRUE(d.detection.success) << d.detection.message;
    EXPECT_LT(ComputeAdd(d.detection.cam_from_object, truth, points), 0.1 * bank_->diameter_m);
    EXPECT_GT(d.wall_ms, 0.0);
  }
  EXPECT_EQ(detector.Completed(), 2);
  EXPECT_TRUE(detector.TakeFinished().empty());
}

TEST_F(BackgroundDetectorTest, AFullQueueRefusesAndStopEndsARunningSolve) {
  BackgroundDetector detector(SolverOptions(), 1, 0);
  Eigen::Isometry3d truth;
  // The jobs are made first and submitted back to back: rendering a frame can take longer
  // than a solve (under ThreadSanitizer), which would let the thread finish one in between.
  std::vector<BackgroundDetector::Job> jobs;
  for (int i = 0; i < 4; ++i) jobs.push_back(MakeJob(i, &truth));
  int accepted = 0;
  for (BackgroundDetector::Job& job : jobs) accepted += detector.Submit(std::move(job));
  // One may already be running, one waits: at most two of the four are taken.
  EXPECT_LE(accepted, 2);
  EXPECT_GE(detector.Rejected(), 2);
  detector.Stop();
  detector.Stop();  // idempotent
  EXPECT_FALSE(detector.Submit(MakeJob(9, &truth)));
}

}  // namespace
}  // namespace g6d
