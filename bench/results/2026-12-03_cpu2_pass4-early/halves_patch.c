/* Added after trace_patch.py's lines in pbe_collective (bench/results/2026-12-03_cpu2_pass4-decrease),
 * before the correction is taken: the second image's ratio to the noise's eigenvalue on the whole sum (part 0),
 * its earlier half (1) and its later half (2), as second_image tests it. */
    if (traced) {
        double zz[NG] = {0}, ee;
        residual(&cv, zz, &ee);
        for (int part = 0; part < 3; part++) {
            size_t lo = part == 2 ? m / 2 : 0, hi = part == 1 ? m / 2 : m, n = hi - lo, f1, f2;
            double *sub = malloc(sizeof(double) * n * n);
            for (size_t i = 0; i < n; i++)
                for (size_t j = 0; j < n; j++)
                    sub[i * n + j] = cv.gram[(lo + i) * m + lo + j];
            int shows = second_image(&cv, sub, n, &f1, &f2);
            /* the ratio second_image tests: sorted eigenvalues */
            double *w = malloc(sizeof(double) * n);
            memcpy(w, cv.w, sizeof(double) * n);
            qsort(w, n, sizeof(double), pb_compare_doubles);
            fprintf(stderr, "TRACE4 part %d frames %zu-%zu shows %d second/noise %.2f\n", part, cv.use[lo], cv.use[hi - 1], shows,
                    w[n - 2] / w[(n - 1) - (cv.rank + (n - cv.rank) / 2)]);
            free(sub);
            free(w);
        }
    }
