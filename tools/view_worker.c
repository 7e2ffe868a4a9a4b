/* The relighting thread (view_internal.h): direct light and solve off the GL thread, so the
 * window keeps the display rate and shows the newest finished radiosity. */
#include "view_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

double view_now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

/* One relight of a copied request into w->work; LRR_OK or the failure. */
static lrr_status relight(view_worker *w, const lrr_light_source *lights, size_t count,
                          int emitters, double *direct_ms, double *solve_ms)
{
    double t0 = view_now_ms();
    lrr_status s = lrr_lighting_direct(w->lighting, lights, count, w->e);
    if (s != LRR_OK)
        return s;
    const float *em = lrr_operator_emission(w->op);
    if (emitters && em)
        for (size_t i = 0; i < 3 * w->n; i++)
            w->e[i] += em[i];
    double t1 = view_now_ms();
    s = lrr_solve(w->solver, w->e, w->work);
    *direct_ms = t1 - t0;
    *solve_ms = view_now_ms() - t1;
    return s;
}

static void *worker_main(void *arg)
{
    view_worker *w = arg;
    lrr_light_source lights[VIEW_MAX_LIGHTS];
    pthread_mutex_lock(&w->mu);
    for (;;) {
        while (!w->quit && w->finished_gen == w->posted)
            pthread_cond_wait(&w->wake, &w->mu);
        if (w->quit)
            break;
        uint64_t gen = w->posted;
        size_t count = w->nlights;
        int emitters = w->emitters;
        memcpy(lights, w->lights, count * sizeof *lights);
        pthread_mutex_unlock(&w->mu);
        double dms = 0, sms = 0;
        lrr_status s = relight(w, lights, count, emitters, &dms, &sms);
        pthread_mutex_lock(&w->mu);
        w->finished_gen = gen;
        if (s != LRR_OK) {
            w->error = s;
            snprintf(w->error_text, sizeof w->error_text, "relighting: %s", lrr_strerror(s));
            pthread_cond_broadcast(&w->done);
            break;
        }
        float *t = w->ready; /* the finished B becomes `ready`; its old buffer is reused */
        w->ready = w->work;
        w->work = t;
        w->ready_gen = gen;
        w->ready_direct_ms = dms;
        w->ready_solve_ms = sms;
        w->relights++;
        w->sum_direct_ms += dms;
        w->sum_solve_ms += sms;
        pthread_cond_broadcast(&w->done);
    }
    pthread_mutex_unlock(&w->mu);
    return NULL;
}

int view_worker_start(view_worker *w, const lrr_operator *op, double shadow_tol)
{
    memset(w, 0, sizeof *w);
    lrr_operator_info info;
    lrr_operator_get_info(op, &info, sizeof info);
    w->op = op;
    w->n = info.n;
    w->work = cli_alloc_rgb(w->n);
    w->ready = cli_alloc_rgb(w->n);
    w->shown = cli_alloc_rgb(w->n);
    w->e = cli_alloc_rgb(w->n);
    if (!w->work || !w->ready || !w->shown || !w->e)
        return -1; /* cli_alloc_rgb reported it */
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_CPU, &w->solver);
    if (s == LRR_OK)
        s = lrr_lighting_create(op, &w->lighting);
    if (s == LRR_OK)
        s = lrr_lighting_set_tolerance(w->lighting, shadow_tol);
    if (s != LRR_OK) {
        fprintf(stderr, "lrr view: cannot start the relighting: %s\n", lrr_strerror(s));
        return -1;
    }
    pthread_mutex_init(&w->mu, NULL);
    pthread_cond_init(&w->wake, NULL);
    pthread_cond_init(&w->done, NULL);
    if (pthread_create(&w->thread, NULL, worker_main, w) != 0) {
        fprintf(stderr, "lrr view: cannot start the relighting thread\n");
        return -1;
    }
    w->started = 1;
    return 0;
}

void view_worker_post(view_worker *w, const lrr_light_source *lights, size_t count,
                      int emitters)
{
    pthread_mutex_lock(&w->mu);
    memcpy(w->lights, lights, count * sizeof *lights);
    w->nlights = count;
    w->emitters = emitters;
    w->posted++;
    pthread_cond_signal(&w->wake);
    pthread_mutex_unlock(&w->mu);
}

int view_worker_take(view_worker *w)
{
    pthread_mutex_lock(&w->mu);
    int fresh = w->ready_gen > w->shown_gen;
    if (fresh) {
        float *t = w->shown;
        w->shown = w->ready;
        w->ready = t;
        w->shown_gen = w->ready_gen;
        w->ready_gen = 0; /* the swapped-in buffer holds an older B: never shown again */
    }
    pthread_mutex_unlock(&w->mu);
    return fresh;
}

int view_worker_failed(view_worker *w)
{
    pthread_mutex_lock(&w->mu);
    int failed = w->error != LRR_OK;
    pthread_mutex_unlock(&w->mu);
    return failed;
}

void view_worker_stats(view_worker *w, uint64_t *relights, double *direct_ms,
                       double *solve_ms)
{
    pthread_mutex_lock(&w->mu);
    *relights = w->relights;
    *direct_ms = w->sum_direct_ms;
    *solve_ms = w->sum_solve_ms;
    pthread_mutex_unlock(&w->mu);
}

int view_worker_wait(view_worker *w)
{
    pthread_mutex_lock(&w->mu);
    while (!w->error && w->finished_gen < w->posted)
        pthread_cond_wait(&w->done, &w->mu);
    int rc = w->error ? -1 : 0;
    pthread_mutex_unlock(&w->mu);
    return rc;
}

void view_worker_stop(view_worker *w)
{
    if (w->started) {
        pthread_mutex_lock(&w->mu);
        w->quit = 1;
        pthread_cond_signal(&w->wake);
        pthread_mutex_unlock(&w->mu);
        pthread_join(w->thread, NULL);
        pthread_mutex_destroy(&w->mu);
        pthread_cond_destroy(&w->wake);
        pthread_cond_destroy(&w->done);
    }
    lrr_lighting_destroy(w->lighting);
    lrr_solver_destroy(w->solver);
    free(w->work);
    free(w->ready);
    free(w->shown);
    free(w->e);
    memset(w, 0, sizeof *w);
}
