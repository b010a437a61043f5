// A job the maintenance socket queues for the cycle runner to run between
// cycles (docs/daemon.md, "Calibration while production is paused"): the
// fixture calibration and the camera snapshot. The queue holds at most one job
// of its kind; its status (state queued, running, done or failed, and the job's
// own fields) is read from other threads while the runner thread runs it.
#pragma once

#include "hullgauge/common/status.h"
#include "hullgauge/station/sequencer.h"

#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace hg::daemon {

template <class Job> class MaintenanceJob {
  public:
    /// `what` names the job in refusals ("a calibration").
    explicit MaintenanceJob(std::string what) : what_(std::move(what)) {}

    /// Queues `job` with its first status fields. A NotAllowed failure saying
    /// why when one is queued or running, or the station (in `state`) is
    /// faulted or starting: the maintenance socket's caller gets the reason,
    /// nothing throws (docs/style.md point 4).
    Status request(Job job, station::SequencerState state, nlohmann::json status)
    {
        using S = station::SequencerState;
        std::lock_guard lock(mutex_);
        if (job_ || running_) return Status::failure(StatusCode::NotAllowed, what_ + " is already queued or running");
        if (state == S::Fault || state == S::Starting || state == S::Calibrating)
            return Status::failure(StatusCode::NotAllowed,
                                   std::string("the station is not ready (") + std::string(enumName(state)) + ")");
        status_ = std::move(status);
        status_["state"] = "queued";
        job_ = std::move(job);
        return Status::success();
    }

    bool queued() const
    {
        std::lock_guard lock(mutex_);
        return job_.has_value();
    }

    /// Takes the queued job (none when none is queued); it is running from now.
    std::optional<Job> take()
    {
        std::lock_guard lock(mutex_);
        std::optional<Job> job;
        job.swap(job_);
        running_ = job.has_value();
        return job;
    }

    /// Puts a taken job back (a trigger was accepted first: its cycle runs first).
    void requeue(Job job)
    {
        std::lock_guard lock(mutex_);
        job_ = std::move(job);
        running_ = false;
    }

    /// Ends a taken job as failed before it started.
    void refuse(const std::string& why) { update({{"state", "failed"}, {"error", why}}); }

    /// Merges `fields` into the status; state done or failed ends the job.
    void update(const nlohmann::json& fields)
    {
        std::lock_guard lock(mutex_);
        status_.update(fields);
        const auto state = fields.value("state", std::string());
        if (state == "done" || state == "failed") running_ = false;
    }

    /// Appends `line` to the status array `key`.
    void append(const char* key, const std::string& line)
    {
        std::lock_guard lock(mutex_);
        status_[key].push_back(line);
    }

    nlohmann::json status() const
    {
        std::lock_guard lock(mutex_);
        return status_;
    }

  private:
    const std::string what_;
    mutable std::mutex mutex_;
    std::optional<Job> job_;
    bool running_ = false;
    nlohmann::json status_ = nullptr;
};

} // namespace hg::daemon
