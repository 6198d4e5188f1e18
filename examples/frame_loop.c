/* The frame loop of frame_loop.cpp through the C API (afterimage/afterimage.h): a renderer
   fills its own buffers with jittered frames, TAA resolves them into the program's output
   buffer, and the last raw frame and TAA output are scored against a supersampled reference.
   Exits non-zero if TAA is not better, or on any error (with the library's one-line message).

   The scene: a rotated checkerboard on a plane at depth 10, scrolling right. Conventions
   (docs/DESIGN.md §3): pixel (0, 0) is the top-left, y down; jitter in pixels; motion =
   p_prev - p_curr in pixels; depth is linear view depth. */
#include <afterimage/afterimage.h>

#include <math.h>
#include <stdio.h>

#define WIDTH 64
#define HEIGHT 36
#define FRAMES 12
#define SPEED 0.25 /* pixels per frame, to the right */

/* The scene's color at image position (x, y) (pixels, continuous) in frame t. */
static void scene(double x, double y, int t, float rgb[3]) {
  /* 5 px squares rotated by 20 degrees, so every edge is aliased; bright squares are HDR. */
  const double c = cos(0.349), s = sin(0.349), px = x - SPEED * t;
  const double u = (px * c + y * s) / 5.0, v = (-px * s + y * c) / 5.0;
  const int dark = ((int)floor(u) + (int)floor(v)) & 1;
  rgb[0] = dark ? 0.05f : 2.0f;
  rgb[1] = dark ? 0.06f : 1.6f;
  rgb[2] = dark ? 0.08f : 1.2f;
}

/* Radical inverse in `base`: the Halton sequence. */
static double halton(int index, int base) {
  double f = 1.0, r = 0.0;
  for (; index > 0; index /= base) {
    f /= base;
    r += f * (index % base);
  }
  return r;
}

/* The renderer's buffers: color RGBA interleaved, depth, motion; TAA's output; the reference. */
static float color[HEIGHT][WIDTH][4], depth[HEIGHT][WIDTH], motion[HEIGHT][WIDTH][2];
static float resolved[HEIGHT][WIDTH][3], reference[HEIGHT][WIDTH][3];

/* Prints the message of the call that just failed and returns 1 (the exit status). */
static int fail(const char* what) {
  fprintf(stderr, "error: %s: %s\n", what, afterimage_last_error());
  return 1;
}

int main(void) {
  afterimage_method taa = NULL;
  afterimage_frame frame;
  afterimage_buffer out, ref;
  double raw_db = 0, taa_db = 0;
  int t, x, y, sx, sy;
  const int n = 8; /* reference samples per pixel per axis */

  printf("afterimage %s (headers %s)\n", afterimage_version(), AFTERIMAGE_VERSION_STRING);
  /* threads 0: every core; simd 1: the vector path (the same bits as the 1-lane one). */
  if (afterimage_method_new("taa:afterimage", NULL, 0, 0, 1, &taa) != AFTERIMAGE_OK)
    return fail("afterimage_method_new");

  afterimage_frame_init(&frame); /* no buffers, default conventions, identity camera */
  frame.color = afterimage_buffer_interleaved(color, WIDTH, HEIGHT, 4, AFTERIMAGE_F32);
  frame.depth = afterimage_buffer_interleaved(depth, WIDTH, HEIGHT, 1, AFTERIMAGE_F32);
  frame.motion = afterimage_buffer_interleaved(motion, WIDTH, HEIGHT, 2, AFTERIMAGE_F32);
  out = afterimage_buffer_interleaved(resolved, WIDTH, HEIGHT, 3, AFTERIMAGE_F32);

  /* A still camera: identity view, a 45 degree perspective projection (row-major). */
  {
    const float f = 1.0f / (float)tan(0.5 * 45.0 * 3.14159265 / 180.0);
    const float z_near = 0.1f, z_far = 100.0f;
    float* p = frame.camera.projection;
    int i;
    for (i = 0; i < 16; ++i) p[i] = 0.0f;
    p[0] = f * HEIGHT / WIDTH;
    p[5] = f;
    p[10] = -(z_far + z_near) / (z_far - z_near);
    p[11] = -2.0f * z_far * z_near / (z_far - z_near);
    p[14] = -1.0f;
    frame.camera.known = 1;
  }

  for (t = 0; t < FRAMES; ++t) {
    /* Halton(2, 3) over 16 phases, skipping index 0, centred on the pixel. */
    frame.camera.jitter_x = (float)(halton(t % 16 + 1, 2) - 0.5);
    frame.camera.jitter_y = (float)(halton(t % 16 + 1, 3) - 0.5);
    frame.camera.index = t;
    frame.camera.time = t / 60.0;
    /* One sample per pixel at the jittered position, as a rasteriser takes it. */
    for (y = 0; y < HEIGHT; ++y)
      for (x = 0; x < WIDTH; ++x) {
        scene(x + 0.5 + frame.camera.jitter_x, y + 0.5 + frame.camera.jitter_y, t, color[y][x]);
        color[y][x][3] = 1.0f;
        depth[y][x] = 10.0f;
        /* The plane moved SPEED px right since the last frame; frame 0 has no last frame. */
        motion[y][x][0] = t == 0 ? 0.0f : (float)-SPEED;
        motion[y][x][1] = 0.0f;
      }
    if (afterimage_method_process(taa, &frame, &out) != AFTERIMAGE_OK) {
      afterimage_method_free(taa);
      return fail("afterimage_method_process");
    }
  }
  afterimage_method_free(taa);

  /* The reference for the last frame: 8 x 8 samples per pixel, a box filter. */
  for (y = 0; y < HEIGHT; ++y)
    for (x = 0; x < WIDTH; ++x) {
      double sum[3] = {0, 0, 0};
      float rgb[3];
      for (sy = 0; sy < n; ++sy)
        for (sx = 0; sx < n; ++sx) {
          scene(x + (sx + 0.5) / n, y + (sy + 0.5) / n, FRAMES - 1, rgb);
          sum[0] += rgb[0];
          sum[1] += rgb[1];
          sum[2] += rgb[2];
        }
      for (sx = 0; sx < 3; ++sx) reference[y][x][sx] = (float)(sum[sx] / (n * n));
    }

  /* PSNR on display values (hdr = 1: Reinhard tonemap, then sRGB); the RGBA frame's RGB. */
  ref = afterimage_buffer_interleaved(reference, WIDTH, HEIGHT, 3, AFTERIMAGE_F32);
  if (afterimage_psnr(&ref, &frame.color, 1, &raw_db) != AFTERIMAGE_OK ||
      afterimage_psnr(&ref, &out, 1, &taa_db) != AFTERIMAGE_OK)
    return fail("afterimage_psnr");
  printf("frame %d: PSNR raw jittered %.2f dB, TAA %.2f dB\n", FRAMES - 1, raw_db, taa_db);
  if (!(taa_db > raw_db)) {
    fprintf(stderr, "TAA did not improve on the raw frame\n");
    return 1;
  }
  return 0;
}
