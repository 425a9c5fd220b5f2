/* A C client of splatphys: prints each frame's step and Gaussian count, then pushes an object.
 *
 *   frames_and_push PREFIX OBJECT [FRAMES]
 *
 * Build (after `cargo build --release -p splatphys-capi`):
 *   cc -I clients/c clients/c/examples/frames_and_push.c target/release/libsplatphys_client.a \
 *      -lpthread -ldl -lm -o frames_and_push
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "splatphys_client.h"

static int report(const char *what, splatphys_Result r) {
    fprintf(stderr, "%s: %d %s\n", what, (int)r, splatphys_last_error());
    return 1;
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s PREFIX OBJECT [FRAMES]\n", argv[0]);
        return 2;
    }
    const char *prefix = argv[1];
    const char *object = argv[2];
    int frames = argc > 3 ? atoi(argv[3]) : 5;

    splatphys_Client *client = NULL;
    splatphys_Result r = splatphys_connect(prefix, 10.0, &client);
    if (r != SPLATPHYS_OK) return report("connect", r);

    for (int i = 0; i < frames; i++) {
        const splatphys_FrameHeader *header = NULL;
        const splatphys_FrameGaussian *gaussians = NULL;
        size_t count = 0;
        r = splatphys_wait_frame(client, 5.0, &header, &gaussians, &count);
        if (r == SPLATPHYS_TIMEOUT) continue;
        if (r != SPLATPHYS_OK) { splatphys_disconnect(client); return report("wait_frame", r); }
        /* Zero-copy: these point into the server's shared memory until released. */
        printf("frame %llu step %llu gaussians %zu first_z %.4f\n",
               (unsigned long long)header->frame_index, (unsigned long long)header->step, count,
               count > 0 ? gaussians[0].position_m[2] : 0.0f);
        splatphys_release_frame(client);
    }

    uint32_t id = 0;
    r = splatphys_object_id(client, object, 5.0, &id);
    if (r != SPLATPHYS_OK) { splatphys_disconnect(client); return report("object_id", r); }

    splatphys_CommandMsg push;
    memset(&push, 0, sizeof push);
    push.kind = SPLATPHYS_COMMAND_IMPULSE;
    push.object_id = id;
    push.vector[0] = 0.0;
    push.vector[1] = 0.0;
    push.vector[2] = 0.01; /* N s, upwards */
    splatphys_ReplyMsg reply;
    r = splatphys_send_command(client, &push, 5.0, &reply);
    if (r == SPLATPHYS_REJECTED) {
        printf("push rejected: %s\n", (const char *)reply.message);
    } else if (r != SPLATPHYS_OK) {
        splatphys_disconnect(client);
        return report("send_command", r);
    } else {
        printf("push accepted for object %u at step %llu\n", id,
               (unsigned long long)reply.effective_step);
    }

    size_t n = 0;
    splatphys_ObjectState objects[64];
    r = splatphys_objects(client, objects, 64, &n, NULL);
    if (r == SPLATPHYS_OK) printf("objects %zu\n", n);
    splatphys_Status status;
    for (int i = 0; i < 3; i++) { /* status twice in a row: it must not block */
        r = splatphys_status(client, 2.0, &status);
        if (r == SPLATPHYS_OK) printf("status step %llu\n", (unsigned long long)status.step);
    }

    splatphys_disconnect(client);
    return 0;
}
