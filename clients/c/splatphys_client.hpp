// A header-only C++17 wrapper of the splatphys C client (splatphys_client.h): RAII for the
// connection and the borrowed frame, exceptions for errors. Link with -lsplatphys_client.
//
//   splatphys::Client client("splatphys/default");
//   while (auto frame = client.wait_frame(1.0)) {          // std::nullopt on a timeout
//       for (const splatphys_FrameGaussian& g : *frame) { /* zero-copy */ }
//   }                                                       // each frame released at scope end
//
// A Frame views shared memory: it must not outlive its Client, and waiting for the next frame
// releases the previous one (an older Frame then reads as empty).
#ifndef SPLATPHYS_CLIENT_HPP
#define SPLATPHYS_CLIENT_HPP

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "splatphys_client.h"

namespace splatphys {

/// A failed call: what() is the library's message, code() its splatphys_Result.
class Error : public std::runtime_error {
  public:
    Error(const std::string &call, splatphys_Result code)
        : std::runtime_error(call + ": " + splatphys_last_error()), code_(code) {}
    splatphys_Result code() const noexcept { return code_; }

  private:
    splatphys_Result code_;
};

class Client;

/// The newest frame, borrowed from shared memory until destroyed (or the next wait).
class Frame {
  public:
    Frame(const Frame &) = delete;
    Frame &operator=(const Frame &) = delete;
    Frame(Frame &&other) noexcept { *this = std::move(other); }
    Frame &operator=(Frame &&other) noexcept;
    ~Frame();

    const splatphys_FrameHeader &header() const { return *header_; }
    const splatphys_FrameGaussian *begin() const { return live() ? gaussians_ : nullptr; }
    const splatphys_FrameGaussian *end() const { return live() ? gaussians_ + count_ : nullptr; }
    std::size_t size() const { return live() ? count_ : 0; }

  private:
    friend class Client;
    Frame(Client *owner, std::uint64_t id, const splatphys_FrameHeader *h,
          const splatphys_FrameGaussian *g, std::size_t n)
        : owner_(owner), id_(id), header_(h), gaussians_(g), count_(n) {}
    bool live() const;

    Client *owner_ = nullptr;
    std::uint64_t id_ = 0;
    const splatphys_FrameHeader *header_ = nullptr;
    const splatphys_FrameGaussian *gaussians_ = nullptr;
    std::size_t count_ = 0;
};

/// A connection to the server under a prefix.
class Client {
  public:
    explicit Client(const std::string &prefix, double timeout_s = 5.0) {
        splatphys_Result r = splatphys_connect(prefix.c_str(), timeout_s, &raw_);
        if (r != SPLATPHYS_OK) throw Error("connect", r);
    }
    Client(const Client &) = delete;
    Client &operator=(const Client &) = delete;
    ~Client() { splatphys_disconnect(raw_); }

    /// The newest frame, or std::nullopt when none arrives within timeout_s.
    std::optional<Frame> wait_frame(double timeout_s) {
        const splatphys_FrameHeader *h = nullptr;
        const splatphys_FrameGaussian *g = nullptr;
        std::size_t n = 0;
        ++current_; // the previous frame is released by the call
        splatphys_Result r = splatphys_wait_frame(raw_, timeout_s, &h, &g, &n);
        if (r == SPLATPHYS_TIMEOUT) return std::nullopt;
        if (r != SPLATPHYS_OK) throw Error("wait_frame", r);
        return Frame(this, current_, h, g, n);
    }

    /// The id of the object a scene file names `name`.
    std::uint32_t object_id(const std::string &name, double timeout_s = 5.0) {
        std::uint32_t id = 0;
        splatphys_Result r = splatphys_object_id(raw_, name.c_str(), timeout_s, &id);
        if (r != SPLATPHYS_OK) throw Error("object_id", r);
        return id;
    }

    /// Sends a command; returns the reply (accepted != 0, or the rejection's code and message).
    splatphys_ReplyMsg send(const splatphys_CommandMsg &command, double timeout_s = 5.0) {
        splatphys_ReplyMsg reply{};
        splatphys_Result r = splatphys_send_command(raw_, &command, timeout_s, &reply);
        if (r != SPLATPHYS_OK && r != SPLATPHYS_REJECTED) throw Error("send_command", r);
        return reply;
    }

    /// The newest objects (empty before the first objects sample).
    std::vector<splatphys_ObjectState> objects() {
        std::size_t n = 0;
        splatphys_Result r = splatphys_objects(raw_, nullptr, 0, &n, nullptr);
        if (r == SPLATPHYS_TIMEOUT) return {};
        std::vector<splatphys_ObjectState> out(n);
        if (r == SPLATPHYS_ERR_BUFFER_TOO_SMALL || r == SPLATPHYS_OK) {
            r = splatphys_objects(raw_, out.data(), out.size(), &n, nullptr);
        }
        if (r != SPLATPHYS_OK) throw Error("objects", r);
        out.resize(n);
        return out;
    }

    /// The newest status, waiting up to timeout_s for the first one.
    splatphys_Status status(double timeout_s = 1.0) {
        splatphys_Status s{};
        splatphys_Result r = splatphys_status(raw_, timeout_s, &s);
        if (r != SPLATPHYS_OK) throw Error("status", r);
        return s;
    }

    /// The underlying C handle.
    splatphys_Client *raw() const noexcept { return raw_; }

  private:
    friend class Frame;
    splatphys_Client *raw_ = nullptr;
    std::uint64_t current_ = 0;
};

inline bool Frame::live() const { return owner_ != nullptr && owner_->current_ == id_; }

inline Frame &Frame::operator=(Frame &&other) noexcept {
    if (this != &other) {
        owner_ = other.owner_;
        id_ = other.id_;
        header_ = other.header_;
        gaussians_ = other.gaussians_;
        count_ = other.count_;
        other.owner_ = nullptr;
    }
    return *this;
}

inline Frame::~Frame() {
    if (live()) {
        splatphys_release_frame(owner_->raw_);
        ++owner_->current_;
    }
}

} // namespace splatphys

#endif // SPLATPHYS_CLIENT_HPP
