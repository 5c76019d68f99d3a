// The run log's journal: what reaches it survives a crash at any byte, and
// recover_run() turns it into a whole run.h5.

#include "io/run_journal.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "io/h5_file.hpp"
#include "io/run_log.hpp"
#include "io/run_recovery.hpp"
#include "piezo/config/config_error.hpp"

namespace piezo::host {
namespace {
namespace fs = std::filesystem;

class RunJournalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("piezo-journal-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "run");
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// `batches` flushes of 100 drive rows (t = row index) and 10 sensor rows.
  static void fill(log_schema::LogRows& rows, int batch) {
    for (int i = 0; i < 100; ++i) {
      const double t = batch * 100 + i;
      rows.drive.t.push_back(t);
      rows.drive.V.push_back(std::sin(t));
      rows.drive.phase.push_back(i % 3);
      rows.drive.status.push_back(0);
      rows.drive.move_state.push_back(0);
      rows.drive.t_received.push_back(t);
    }
    for (int i = 0; i < 10; ++i) {
      const double t = batch * 10 + i;
      rows.sensor.t.push_back(t);
      rows.sensor.t_response.push_back(t);
      rows.sensor.displacement_m.push_back(1e-6 * t);
      rows.sensor.theta.push_back(i == 5 ? std::nan("") : 1e-3 * t);
      rows.sensor.status.push_back(i == 5 ? 2 : 0);
      rows.sensor.t_received.push_back(t);
    }
  }

  std::string log_path() const { return (dir_ / "run" / "run.h5").string(); }
  std::string journal() const { return (dir_ / "run" / "run.journal").string(); }
  fs::path dir_;
};

TEST_F(RunJournalTest, HoldsEveryFlushedRowAndTheHeader) {
  {
    RunJournal j = RunJournal::create(journal(), {{"config", "[drive]"}, {"utc_start", "x"}});
    for (int b = 0; b < 3; ++b) {
      log_schema::LogRows rows;
      fill(rows, b);
      log_schema::AxesRows one{rows};
      j.append(one, {""});
    }
    j.set_attribute("board_t0_ns", "42");
  }
  const JournalContents c = read_journal(journal());
  EXPECT_EQ(c.blocks, 5u);
  EXPECT_EQ(c.torn_bytes, 0u);
  EXPECT_EQ(c.header.at("config"), "[drive]");
  EXPECT_EQ(c.attributes.at("board_t0_ns"), "42");
  ASSERT_EQ(c.rows.front().drive.t.size(), 300u);
  ASSERT_EQ(c.rows.front().sensor.theta.size(), 30u);
  for (std::size_t i = 0; i < 300; ++i)
    EXPECT_EQ(c.rows.front().drive.t[i], static_cast<double>(i));
  EXPECT_TRUE(std::isnan(c.rows.front().sensor.theta[5]));
  EXPECT_EQ(c.rows.front().sensor.theta[6], 6e-3);
}

TEST_F(RunJournalTest, ATornOrCorruptTailLosesOnlyItsBlock) {
  {
    RunJournal j = RunJournal::create(journal(), {{"utc_start", "x"}});
    for (int b = 0; b < 3; ++b) {
      log_schema::LogRows rows;
      fill(rows, b);
      log_schema::AxesRows one{rows};
      j.append(one, {""});
    }
  }
  const auto size = fs::file_size(journal());
  const JournalContents whole = read_journal(journal());
  // Cut the file at every byte of the last block: two batches always remain.
  const auto two_blocks_end = [&] {
    fs::copy_file(journal(), journal() + ".copy");
    fs::resize_file(journal() + ".copy", size - 1);
    const JournalContents c = read_journal(journal() + ".copy");
    fs::remove(journal() + ".copy");
    return size - 1 - c.torn_bytes;
  }();
  for (auto cut = two_blocks_end; cut < size; cut += 7) {
    fs::resize_file(journal(), cut);
    const JournalContents c = read_journal(journal());
    EXPECT_EQ(c.rows.front().drive.t.size(), 200u) << "cut at " << cut;
    EXPECT_EQ(c.torn_bytes, cut - two_blocks_end);
  }
  // A flipped bit inside the second block: its CRC fails, the first stays.
  fs::resize_file(journal(), two_blocks_end);
  {
    std::fstream f(journal(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(two_blocks_end - 20));
    f.put('\x5a');
  }
  EXPECT_EQ(read_journal(journal()).rows.front().drive.t.size(), 100u);
  EXPECT_EQ(whole.rows.front().drive.t.size(), 300u);
}

TEST_F(RunJournalTest, NotAJournalIsSaidSo) {
  std::ofstream(journal()) << "drive,t\n1,2\n";
  try {
    (void)read_journal(journal());
    FAIL() << "read a CSV as a journal";
  } catch (const config::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("not a run journal"), std::string::npos) << e.what();
  }
}

// A log abandoned after three flushes (as a kill leaves it): recovery gives a
// whole file with every row, marked recovered, and the journal goes.
TEST_F(RunJournalTest, RecoverRebuildsAnAbandonedLog) {
  {
    RunLog log = RunLog::create(log_path(), {{"config", "[drive]"}, {"utc_start", "x"}}, {"rotor"});
    for (int b = 0; b < 3; ++b) {
      log_schema::LogRows rows;
      fill(rows, b);
      log.append(rows);
    }
    log.set_attribute("board_t0_ns", "7");
    log.abandon();
  }
  // A run still writing is not touched: the journal is locked while held.
  ASSERT_TRUE(fs::exists(journal()));
  const Recovery r = recover_run((dir_ / "run").string());
  EXPECT_TRUE(r.rebuilt);
  EXPECT_EQ(r.drive_rows, 300u);
  EXPECT_EQ(r.sensor_rows, 30u);
  EXPECT_FALSE(fs::exists(journal()));
  const H5File f = H5File::open(log_path());
  EXPECT_EQ(f.attribute("/", "status"), "recovered");
  EXPECT_EQ(f.attribute("/", "config"), "[drive]");
  EXPECT_EQ(f.attribute("/", "board_t0_ns"), "7");
  EXPECT_EQ(f.read("/axes/rotor/drive/t").size(), 300u);
  EXPECT_EQ(f.read("/axes/rotor/drive/phase")[2], 2.0);
  EXPECT_TRUE(std::isnan(f.read("/axes/rotor/sensor/theta")[5]));
  // Again: nothing to do.
  EXPECT_FALSE(recover_run((dir_ / "run").string()).rebuilt);
  EXPECT_TRUE(fs::exists(dir_ / "catalogue.csv"));
}

// A group move's log abandoned mid-run: each axis's rows come back under
// its own group, with its own attributes, and nothing of one reaches another.
TEST_F(RunJournalTest, RecoverRebuildsEachAxisOfAGroupLog) {
  {
    RunLog log = RunLog::create(log_path(), {{"utc_start", "x"}}, {"theta", "phi"});
    for (int b = 0; b < 3; ++b) {
      log_schema::AxesRows rows(2);
      fill(rows[0], b);
      fill(rows[1], b);
      for (double& v : rows[1].drive.V) v = -v;  // phi's own values
      if (b == 2) rows[1].drive = {};            // phi's drive ended before the last flush
      log.append(rows);
    }
    log.set_axis_attribute(1, "theta_zero_m", "0.5");
    log.abandon();
  }
  const Recovery r = recover_run((dir_ / "run").string());
  EXPECT_TRUE(r.rebuilt);
  EXPECT_EQ(r.drive_rows, 500u);
  EXPECT_EQ(r.sensor_rows, 60u);
  const H5File f = H5File::open(log_path());
  EXPECT_EQ(f.attribute("/", "axes"), "theta,phi");
  EXPECT_EQ(f.read("/axes/theta/drive/t").size(), 300u);
  EXPECT_EQ(f.read("/axes/phi/drive/t").size(), 200u);
  EXPECT_EQ(f.read("/axes/phi/drive/V")[7], -f.read("/axes/theta/drive/V")[7]);
  EXPECT_EQ(f.read("/axes/phi/sensor/theta").size(), 30u);
  EXPECT_EQ(f.attribute("/axes/phi", "theta_zero_m"), "0.5");
  EXPECT_FALSE(f.exists("/drive/t")) << "nothing at the root";
  EXPECT_FALSE(recover_run((dir_ / "run").string()).rebuilt);
}

TEST_F(RunJournalTest, AClosedLogLeavesNoJournal) {
  RunLog log = RunLog::create(log_path(), {{"utc_start", "x"}}, {"rotor"});
  log_schema::LogRows rows;
  fill(rows, 0);
  log.append(rows);
  EXPECT_TRUE(fs::exists(journal()));
  log.close("completed");
  EXPECT_FALSE(fs::exists(journal()));
  EXPECT_FALSE(recover_run((dir_ / "run").string()).rebuilt);
}

TEST_F(RunJournalTest, ALiveRunIsNotRecoveredUnderItsWriter) {
  RunLog log = RunLog::create(log_path(), {{"utc_start", "x"}}, {"rotor"});
  EXPECT_THROW((void)recover_run((dir_ / "run").string()), config::ConfigError);
  recover_if_needed(log_path());  // readers leave it alone too
  EXPECT_TRUE(fs::exists(journal()));
  log.close("completed");
}

TEST_F(RunJournalTest, AnUnreadableLogWithoutAJournalIsAClearError) {
  std::ofstream(log_path()) << "not hdf5";
  try {
    (void)recover_run((dir_ / "run").string());
    FAIL() << "recovered nothing";
  } catch (const config::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no run.journal"), std::string::npos) << e.what();
  }
}

TEST_F(RunJournalTest, ADatasetClaimingMoreThanTheFileHoldsIsCalledDamaged) {
  // A chunked dataset may claim any length without its bytes (the kill
  // test and a byte-flipping fuzz of run.h5 both met such headers); reading
  // it must be an error naming the dataset, not an allocation of terabytes.
  {
    const hid_t file = H5Fcreate(log_path().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hsize_t claimed = hsize_t{1} << 40, chunk = 1024;
    const hid_t space = H5Screate_simple(1, &claimed, nullptr);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 1, &chunk);
    const hid_t dset =
        H5Dcreate2(file, "t", H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    ASSERT_GE(dset, 0);
    H5Dclose(dset);
    H5Pclose(dcpl);
    H5Sclose(space);
    H5Fclose(file);
  }
  const H5File f = H5File::open(log_path());
  try {
    (void)f.read("t");
    FAIL() << "read a dataset of 2^40 values";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("t in " + log_path() + " claims 1099511627776 values"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("damaged"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace piezo::host
