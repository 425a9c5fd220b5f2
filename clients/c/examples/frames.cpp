// The C++ wrapper: count frames and Gaussians, push an object, RAII throughout.
//   frames_cpp PREFIX OBJECT [FRAMES]
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "splatphys_client.hpp"

int main(int argc, char **argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s PREFIX OBJECT [FRAMES]\n", argv[0]);
        return 2;
    }
    try {
        splatphys::Client client(argv[1], 10.0);
        int frames = argc > 3 ? std::atoi(argv[3]) : 5;
        for (int i = 0; i < frames; i++) {
            auto frame = client.wait_frame(5.0);
            if (!frame) continue;
            std::size_t finite = 0;
            for (const splatphys_FrameGaussian &g : *frame) finite += g.position_m[2] == g.position_m[2];
            std::printf("c++ frame %llu gaussians %zu finite %zu\n",
                        (unsigned long long)frame->header().frame_index, frame->size(), finite);
        }
        splatphys_CommandMsg push;
        std::memset(&push, 0, sizeof push);
        push.kind = SPLATPHYS_COMMAND_IMPULSE;
        push.object_id = client.object_id(argv[2]);
        push.vector[2] = 0.01;
        splatphys_ReplyMsg reply = client.send(push);
        std::printf("c++ push %s\n", reply.accepted ? "accepted" : "rejected");
        std::printf("c++ objects %zu\n", client.objects().size());
        std::printf("c++ status step %llu\n", (unsigned long long)client.status(2.0).step);
    } catch (const splatphys::Error &e) {
        std::fprintf(stderr, "%s (%d)\n", e.what(), (int)e.code());
        return 1;
    }
    return 0;
}
