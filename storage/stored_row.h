#ifndef WAYMARK_STORAGE_STORED_ROW_H_
#define WAYMARK_STORAGE_STORED_ROW_H_

// One row of a query's result, whichever backend ran the query. The SQLite and PostgreSQL stores
// select the same columns in the same order, so the code that turns a row into a record (and
// decides that a row is unreadable: DATA_LOSS) is written once against this interface
// (slam_records.h, token_records.h) instead of once per backend.

#include <cstdint>
#include <optional>
#include <string>

#include "absl/strings/string_view.h"
#include "storage/postgres/pg.h"
#include "storage/sqlite.h"

namespace waymark::storage {

class StoredRow {
 public:
  virtual ~StoredRow() = default;

  virtual bool IsNull(int column) const = 0;
  virtual int64_t Int64(int column) const = 0;
  virtual double Double(int column) const = 0;
  // Raw bytes of a text or blob column (empty for NULL), valid while the row is.
  virtual absl::string_view Bytes(int column) const = 0;

  int32_t Int32(int column) const { return static_cast<int32_t>(Int64(column)); }
  std::string Text(int column) const { return std::string(Bytes(column)); }
  std::optional<double> OptionalDouble(int column) const {
    if (IsNull(column)) return std::nullopt;
    return Double(column);
  }
};

// The row a SQLite statement has just stepped to.
class SqliteRow final : public StoredRow {
 public:
  explicit SqliteRow(const sqlite::Statement& statement) : statement_(statement) {}

  bool IsNull(int column) const override { return statement_.ColumnIsNull(column); }
  int64_t Int64(int column) const override { return statement_.ColumnInt64(column); }
  double Double(int column) const override { return statement_.ColumnDouble(column); }
  absl::string_view Bytes(int column) const override {
    // For a TEXT value sqlite3_column_blob gives its UTF-8 bytes, as ColumnText would.
    return statement_.ColumnBlobView(column);
  }

 private:
  const sqlite::Statement& statement_;
};

// Row `row` of a PostgreSQL result.
class PgRow final : public StoredRow {
 public:
  PgRow(const pg::Result& result, int row) : result_(result), row_(row) {}

  bool IsNull(int column) const override { return result_.IsNull(row_, column); }
  int64_t Int64(int column) const override { return result_.Int64(row_, column); }
  double Double(int column) const override { return result_.Double(row_, column); }
  absl::string_view Bytes(int column) const override { return result_.Bytes(row_, column); }

 private:
  const pg::Result& result_;
  const int row_;
};

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_STORED_ROW_H_
