// The one status value of every call that must not throw: the drivers' cyclic
// and lifecycle calls, the daemon's device port and the calibration sequence's
// move/grab callbacks (docs/style.md point 4). A status is success, or a failure
// with a code that says what kind of failure it was (the sequencer maps the
// code to its events and the PLC's fault codes, docs/plc.md) and a message for
// people that names the device and what went wrong.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "hullgauge/common/enum_names.h"

namespace hg {

enum class StatusCode {
    Ok,
    Timeout,            ///< no answer, frame or position within the time allowed
    Fault,              ///< the device reports a fault of its own (a drive fault code)
    CommunicationError, ///< no connection, refused, exception reply, malformed frame
    IoError,            ///< a local device (GPIO chip, video node, file) could not be opened or written
    NotAllowed,         ///< not allowed in this lifecycle state, or a value out of range
    BadFrame,           ///< a frame arrived but is incomplete or corrupt
    Error,              ///< anything else
};

constexpr auto nameTable(StatusCode)
{
    using enum StatusCode;
    return std::to_array<EnumName<StatusCode>>({{Ok, "ok"},
                                                {Timeout, "timeout"},
                                                {Fault, "fault"},
                                                {CommunicationError, "communication error"},
                                                {IoError, "i/o error"},
                                                {NotAllowed, "not allowed"},
                                                {BadFrame, "bad frame"},
                                                {Error, "error"}});
}

class [[nodiscard]] Status {
  public:
    Status() = default; ///< success
    static Status success() { return {}; }
    static Status failure(StatusCode code, std::string message) { return Status(code, std::move(message)); }
    static Status failure(std::string message) { return Status(StatusCode::Error, std::move(message)); }

    bool ok() const { return code_ == StatusCode::Ok; }
    explicit operator bool() const { return ok(); }
    StatusCode code() const { return code_; }
    const std::string& message() const { return message_; }
    /// The same failure with `prefix` in front of its message ("camera: " + ...).
    Status prefixed(std::string_view prefix) const
    {
        return ok() ? *this : Status(code_, std::string(prefix) + message_);
    }

  private:
    Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}
    StatusCode code_ = StatusCode::Ok;
    std::string message_;
};

/// A value, or the failure that prevented it.
template <class T> class [[nodiscard]] Result {
  public:
    Result(T value) : value_(std::move(value)) {}           // NOLINT: implicit by design
    Result(Status failure) : status_(std::move(failure)) {} // NOLINT
    bool ok() const { return value_.has_value(); }
    explicit operator bool() const { return ok(); }
    const T& value() const { return *value_; }
    T& value() { return *value_; }
    const Status& status() const { return status_; }
    StatusCode code() const { return status_.code(); }
    const std::string& message() const { return status_.message(); }

  private:
    std::optional<T> value_;
    Status status_;
};

} // namespace hg
