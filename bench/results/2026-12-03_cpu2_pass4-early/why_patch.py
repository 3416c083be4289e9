p='src/estimate/contrast_poses.c'
s=open(p).read()
old='''    if (!contrast_near_reference(cv, ref) || !second_image(cv, cv->gram, m, &first, &second))
        return 0;'''
new='''    int near_ok = contrast_near_reference(cv, ref), whole_ok = second_image(cv, cv->gram, m, &first, &second);
    if (getenv("PETBLUR_TRACE4"))
        fprintf(stderr, "TRACE4 why near %d whole %d\\n", near_ok, whole_ok);
    if (!near_ok || !whole_ok)
        return 0;'''
assert old in s; s=s.replace(old,new,1)
old='''    return steps <= CONTRAST_ROUGHNESS * spread && weights_follow_uptake(cv);'''
new='''    if (getenv("PETBLUR_TRACE4"))
        fprintf(stderr, "TRACE4 why rough %.3f follow %d\\n", steps / spread, weights_follow_uptake(cv));
    return steps <= CONTRAST_ROUGHNESS * spread && weights_follow_uptake(cv);'''
assert old in s; s=s.replace(old,new,1)
old='''    if (st == PB_OK && cw &&
        sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) <= voxel &&'''
new='''    if (traced && cw)
        fprintf(stderr, "TRACE4 why bound shift %.3f turn %.3f voxel %.3f\\n", sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), sqrt(p[3] * p[3] + p[4] * p[4] + p[5] * p[5]), voxel);
    if (st == PB_OK && cw &&
        sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) <= voxel &&'''
assert old in s; s=s.replace(old,new,1)
open(p,'w').write(s)
