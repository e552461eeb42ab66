"""svhdesc/compiler"""
