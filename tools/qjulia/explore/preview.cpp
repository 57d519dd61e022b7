#include "preview.h"

#include "qjulia/base/error.h"

namespace qjulia::explore {

std::string empty_solid(const Params& params, const RunStats& stats) {
  return empty_mesh_message(params, stats) +
         (removed_as_dust(stats)
              ? std::string()
              : ". Hint: check the bailout, the iterations, the box and the clip planes");
}

bool says_empty_solid(const std::string& message) {
  return message.find("the solid is empty") != std::string::npos ||
         message.find("smaller than the dust threshold") != std::string::npos;
}

void PreviewLane::run(const std::function<void(const CancelToken&)>& job) {
  std::shared_ptr<CancelToken> token;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    if (shut_down_) throw Cancelled();
    const std::uint64_t ticket = ++newest_;
    if (running_) {
      why_ = "cancelled: a newer preview started";
      token_->request();
    }
    idle_.wait(lock, [&] { return !running_ || shut_down_ || newest_ != ticket; });
    if (shut_down_) throw Cancelled();
    if (newest_ != ticket) throw PreviewCancelled("cancelled: a newer preview started");
    running_ = true;
    token = std::make_shared<CancelToken>();
    token_ = token;
    why_.clear();
  }
  const auto finish = [this] {
    std::lock_guard<std::mutex> lock(mutex_);
    running_ = false;
    token_.reset();
    idle_.notify_all();
  };
  try {
    job(*token);
  } catch (const Cancelled&) {
    std::string why;
    bool shut_down = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      why = why_;
      shut_down = shut_down_;
    }
    finish();
    if (shut_down || why.empty()) throw;
    throw PreviewCancelled(why);
  } catch (...) {
    finish();
    throw;
  }
  finish();
}

bool PreviewLane::stop() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!running_) return false;
  why_ = "cancelled: stopped";
  token_->request();
  return true;
}

void PreviewLane::shutdown() {
  std::lock_guard<std::mutex> lock(mutex_);
  shut_down_ = true;
  if (token_) token_->request();
  idle_.notify_all();
}

std::shared_ptr<const PreviewMesh> MeshCache::find(const std::string& key) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (it->first != key) continue;
    entries_.splice(entries_.begin(), entries_, it);  // the newest again
    return entries_.front().second;
  }
  return nullptr;
}

void MeshCache::put(const std::string& key, std::shared_ptr<const PreviewMesh> mesh) {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.remove_if([&](const auto& e) { return e.first == key; });
  entries_.emplace_front(key, std::move(mesh));
  while (entries_.size() > capacity_) entries_.pop_back();
}

}  // namespace qjulia::explore
